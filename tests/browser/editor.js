'use strict';
// The Node-RED editor of a real Node-RED process (tests/integration/support/node-red.js) in
// headless Chromium, in English whatever the machine's locale, once it has drawn the flows.
const fs = require('fs');
const os = require('os');
const path = require('path');
const puppeteer = require('puppeteer-core');
const { NodeRedProcess } = require('../integration/support/node-red');

const CHROMIUM = process.env.CHROMIUM_BIN || '/usr/bin/chromium';

/**
 * Starts Node-RED on `flows` and opens its editor; resolves once node `readyNode` is drawn.
 * `close(test)` ends both (keeping Node-RED's log for a failed test).
 */
async function openEditor({ flows, tag, readyNode }) {
  const red = new NodeRedProcess({ flows, tag });
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-chromium-'));
  let browser = null;
  async function close(test) {
    if (browser) await browser.close();
    fs.rmSync(profile, { recursive: true, force: true });
    await red.finish(test);
  }
  try {
    await red.start({ waitForBroker: false });
    browser = await puppeteer.launch({
      executablePath: CHROMIUM,
      headless: true,
      args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking',
        '--disable-component-update', '--disable-sync', `--user-data-dir=${profile}`],
    });
    const page = await browser.newPage();
    await page.setViewport({ width: 1400, height: 1000 });
    await page.evaluateOnNewDocument(() => localStorage.setItem('editor-language', 'en-US'));
    await page.goto(`http://127.0.0.1:${red.port}/`, { waitUntil: 'domcontentloaded' });
    await page.waitForFunction((id) => window.RED && RED.nodes && RED.nodes.node(id) && $('.red-ui-header-toolbar').is(':visible')
      && !$('#red-ui-loading-progress').is(':visible'), { timeout: 90000 }, readyNode);
    return { red, browser, page, close };
  } catch (err) {
    await close();
    throw err;
  }
}

/**
 * Resolves once the newest edit tray has opened: Node-RED focuses the tray's first field a timer
 * after it opens, so keys typed before that can land in the wrong field.
 */
async function trayOpened(page) {
  await page.waitForFunction(() => {
    const tray = $('.red-ui-tray').last()[0];
    return Boolean(tray) && tray.contains(document.activeElement);
  }, { timeout: 15000 });
}

module.exports = { openEditor, trayOpened };
