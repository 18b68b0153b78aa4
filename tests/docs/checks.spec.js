'use strict';
// The docs checks themselves catch what they are for: a link to a missing
// file or heading, a built page linking to a missing id, a code table that
// cannot be read, an untagged snippet; and GitHub's anchors are what the
// checks and the site compute.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const { anchors, links, parse, slug } = require('../../scripts/docs/markdown');
const { brokenLinks, htmlLinks } = require('../../scripts/docs/links');
const { missingAnchors } = require('../../scripts/docs/site');
const { parseCodes, codesMarkdown, withTable } = require('../../scripts/docs/codes');
const { untested, onPorts } = require('../../scripts/docs/snippets');

describe('docs checks', function () {
  it('makes GitHub\'s anchors: punctuation dropped, code kept, repeats numbered', function () {
    assert.equal(slug('Control: PID, Smith predictor, RCC'), 'control-pid-smith-predictor-rcc');
    assert.equal(slug('Faults, redeploys and restarts'), 'faults-redeploys-and-restarts');
    const text = '# Title\n\n### `esphome` (stock ESPHome MQTT, `<p>` = prefix)\n\n## Topics\n\n```sh\n# not a heading\n```\n\n## Topics\n';
    assert.deepEqual(anchors(text), ['title', 'esphome-stock-esphome-mqtt-p--prefix', 'topics', 'topics-1']);
  });

  it('reads links outside code, and fences with their tags', function () {
    const text = 'See [a](a.md#x) and `[not](b.md)`,\n![pic](p.png).\n\n```json plant\n{}\n```\n\n```sh skip: needs Docker here\nx\n```\n';
    assert.deepEqual(links(text).map((l) => l.target), ['a.md#x', 'p.png']);
    const { fences } = parse(text);
    assert.deepEqual(fences.map((f) => [f.lang, f.tags]), [['json', { plant: true }], ['sh', { skip: 'needs Docker here' }]]);
    assert.deepEqual(htmlLinks('<a href="https://github.com/sugarshack/sugarshack/blob/main/docs/x.md#y">x</a>').map((l) => l.target),
      ['https://github.com/sugarshack/sugarshack/blob/main/docs/x.md#y']);
  });

  it('finds a link to a missing file, a missing heading, one that leaves the repository, and one from the site root', function () {
    const files = { 'docs/a.md': new Set(['intro']), 'README.md': new Set(['start']) };
    const fsops = { exists: (f) => f in files || f === 'docs', anchorsOf: (f) => files[f] };
    const found = [
      { line: 1, target: 'a.md#intro' },
      { line: 2, target: '../README.md#start' },
      { line: 3, target: 'https://github.com/sugarshack/sugarshack/blob/main/docs/a.md#intro' },
      { line: 4, target: 'https://nodered.org/docs/' },
      { line: 5, target: 'b.md' },
      { line: 6, target: 'a.md#outro' },
      { line: 7, target: '../../elsewhere.md' },
      { line: 8, target: '/docs/a.md' },
      { line: 9, target: 'https://github.com/sugarshack/sugarshack/blob/main/docs/a.md#gone' },
    ];
    const broken = brokenLinks([{ file: 'docs/index.md', found }], fsops);
    assert.deepEqual(broken.map((b) => b.line), [5, 6, 7, 8, 9]);
    assert.match(broken[1].why, /no heading in docs\/a\.md has the anchor #outro/);
  });

  it('finds a built page\'s link to an id that is not in its target', function () {
    const out = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-site-'));
    try {
      fs.mkdirSync(path.join(out, 'docs'));
      fs.writeFileSync(path.join(out, 'index.html'), '<h2 id="start">x</h2><a href="/docs/a.html#there">a</a><a href="#start">s</a>');
      fs.writeFileSync(path.join(out, 'docs', 'a.html'), '<h2 id="there">x</h2><a href="./../#gone">home</a><a href="b.html#x">b</a>');
      assert.deepEqual(missingAnchors(out), ['docs/a.html: ./../#gone: no id "gone" in index.html', 'docs/a.html: b.html#x: no page docs/b.html']);
    } finally {
      fs.rmSync(out, { recursive: true, force: true });
    }
  });

  it('reads the core\'s code table, and refuses a line it cannot read', function () {
    const source = 'codes! {\n    // ---- the interlock\n    /// The queue is at its bound.\n    QueueFull = "QUEUE_FULL", "queue full", "the interlock queue is full";\n}\n';
    const rows = parseCodes(source);
    assert.deepEqual(rows, [{ section: 'the interlock', code: 'QUEUE_FULL', status: 'queue full', stem: 'the interlock queue is full', means: 'The queue is at its bound.' }]);
    assert.match(codesMarkdown(rows), /### The interlock\n\n\| code \| status \| message stem \| when \|\n\|---\|---\|---\|---\|\n\| `QUEUE_FULL` \| `queue full` \|/);
    assert.throws(() => parseCodes('codes! {\n    QueueFull = QUEUE_FULL;\n}\n'), /cannot read this line/);
    assert.throws(() => withTable('# no markers\n', 'x'), /no <!-- codes/);
  });

  it('refuses a snippet that does not say how it is tested', function () {
    const fence = (info) => ({ ...parse(`\`\`\`${info}\nx\n\`\`\`\n`).fences[0] });
    assert.equal(untested(fence('json plant')), null);
    assert.equal(untested(fence('sh run stack')), null);
    assert.equal(untested(fence('sh run broker until=connected')), null);
    assert.equal(untested(fence('sh by=tests/x.spec.js')), null);
    assert.equal(untested(fence('text')), null);
    assert.match(untested(fence('sh')), /no test tag/);
    assert.match(untested(fence('json')), /one tag/);
    assert.match(untested(fence('sh skip:')), /needs its reason/);
    assert.match(untested(fence('sh run stack broker')), /one of broker and stack/);
    assert.match(untested(fence('sh run quickly')), /unknown tag/);
  });

  it('moves npm start\'s ports to the test\'s', function () {
    const text = 'curl http://127.0.0.1:1880/x\nnpx mqtt pub -h 127.0.0.1 -t t -m m\nbroker: \'mqtt://127.0.0.1:1883\'';
    assert.equal(onPorts(text, { red: 4001, mqtt: 4002 }),
      'curl http://127.0.0.1:4001/x\nnpx mqtt pub -h 127.0.0.1 -p 4002 -t t -m m\nbroker: \'mqtt://127.0.0.1:4002\'');
  });
});
