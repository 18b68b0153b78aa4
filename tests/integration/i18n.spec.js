'use strict';
// The texts built in JS come from the catalogs a real Node-RED process loads:
// an acquire refusing its configured priority logs its error in English from
// the palette as installed, and in German from the same palette with a "de"
// catalog beside en-US when the runtime's language (settings.lang) is "de".
//
// Run: npx mocha --timeout 30000 --exit tests/integration/i18n.spec.js
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { NodeRedProcess, waitFor } = require('./support/node-red');
const { settingsFile } = require('../../scripts/lib/node-red-process');
const { SHARED_NAMESPACE } = require('../../node-red-contrib-sugarshack/lib/host/i18n');

const PALETTE = path.resolve(__dirname, '..', '..', 'node-red-contrib-sugarshack');
const ENGLISH = 'the configured priority must be a whole number, like 5 (higher is more urgent); got "urgent"';
const GERMAN = 'die eingestellte Priorität muss eine ganze Zahl sein, nicht "urgent"';

const flows = [
  { id: 't1', type: 'tab', label: 'i18n' },
  { id: 'il', type: 'sugarshack-interlock', name: 'plant', resources: [{ name: 'YEL', lockout: '' }], policy: 'greedy', queueBound: '', warnQueued: '', warnHeld: '', persist: false, store: 'default' },
  { id: 'in', z: 't1', type: 'inject', props: [{ p: 'payload' }], payload: '', payloadType: 'date', repeat: '', once: true, onceDelay: 0.2, wires: [['a']] },
  { id: 'a', z: 't1', type: 'sugarshack-acquire', name: 'bad priority', interlock: 'il', operation: '10', priority: 'urgent', resources: 'YEL', timeout: 0, wires: [[]] },
];

/**
 * The palette in the user directory as files linking to this one, with nodes/locales/de
 * holding a German catalog for the interlock set (lib/'s texts live there).
 */
function installWithGerman(red) {
  const installed = path.join(red.dir, 'node_modules', 'node-red-contrib-sugarshack');
  fs.unlinkSync(installed);
  fs.mkdirSync(path.join(installed, 'nodes', 'locales', 'de'), { recursive: true });
  for (const entry of fs.readdirSync(PALETTE)) if (entry !== 'nodes') fs.symlinkSync(path.join(PALETTE, entry), path.join(installed, entry));
  for (const entry of fs.readdirSync(path.join(PALETTE, 'nodes'))) {
    if (entry !== 'locales') fs.symlinkSync(path.join(PALETTE, 'nodes', entry), path.join(installed, 'nodes', entry));
  }
  fs.symlinkSync(path.join(PALETTE, 'nodes', 'locales', 'en-US'), path.join(installed, 'nodes', 'locales', 'en-US'), 'dir');
  const german = {
    sugarshack: {
      errors: { priorityNotInteger: '__from__ muss eine ganze Zahl sein, nicht __got__' },
      labels: { configuredPriority: 'die eingestellte Priorität' },
    },
  };
  fs.writeFileSync(path.join(installed, 'nodes', 'locales', 'de', 'interlock.json'), JSON.stringify(german));
  fs.writeFileSync(path.join(red.dir, 'settings.js'), settingsFile(red.dir, { extra: "\n  lang: 'de'," }));
}

describe('texts of a real Node-RED process', function () {
  this.timeout(90000);
  let red = null;

  afterEach(async function () {
    if (red) {
      await red.stop();
      red.remove();
    }
    red = null;
  });

  it('an error built in JS is logged in English from the installed palette', async function () {
    red = new NodeRedProcess({ flows, tag: 'i18n-en' });
    await red.start({ waitForBroker: false });
    await waitFor(() => red.logOfThisRun().includes(ENGLISH), `"${ENGLISH}" in the log`);
    assert.ok(!red.logOfThisRun().includes('sugarshack.errors.'), 'no catalog key shown instead of a text');
  });

  it(`with settings.lang "de" and a de catalog in ${SHARED_NAMESPACE}'s locales, the same error is logged in German`, async function () {
    red = new NodeRedProcess({ flows, tag: 'i18n-de' });
    installWithGerman(red);
    await red.start({ waitForBroker: false, started: 'Flows sind gestartet' });
    await waitFor(() => red.logOfThisRun().includes(GERMAN), `"${GERMAN}" in the log`);
    assert.ok(!red.logOfThisRun().includes(ENGLISH));
  });
});
