'use strict';
// Docs as tests: every fenced block of the docs site's pages (README.md,
// CONTRIBUTING.md, docs/) says in its info string how it is tested, and is
// tested so; the tags are read in scripts/docs/snippets.js.
const assert = require('node:assert/strict');
const fs = require('fs');
const path = require('path');
const { ROOT, read } = require('../../scripts/docs/markdown');
const { ENVS, SNIPPET_MS, docBlocks, untested, run } = require('../../scripts/docs/snippets');
const { Session, sleep } = require('../../scripts/lib/node-red-process');
const { startSimulator, RESULT_TOPIC } = require('../../scripts/simulator');
const { buildModel } = require('../../scripts/simulator/plant');
const { validatePlant } = require('../../node-red-contrib-sugarshack/lib/plant/plant');

const blocks = docBlocks();

describe('docs as tests: the fenced blocks of the docs', function () {
  it('finds the docs\' blocks', function () {
    assert.ok(blocks.length >= 10, `only ${blocks.length} fenced blocks found`);
  });

  it('every block says how it is tested', function () {
    const bad = blocks.map((b) => [b, untested(b)]).filter(([, why]) => why).map(([b, why]) => `${b.where}: \`\`\`${b.info}: ${why}`);
    assert.deepEqual(bad, []);
  });

  for (const block of blocks.filter((b) => b.lang === 'json' && b.tags.plant)) {
    it(`${block.where}: the plant document passes the plant check`, function () {
      const { errors } = validatePlant(block.body);
      assert.deepEqual(errors, []);
    });
  }

  for (const block of blocks.filter((b) => b.lang === 'json' && b.tags.simulation)) {
    it(`${block.where}: the simulator builds this simulation section for the case-study plant`, function () {
      const { simulation } = JSON.parse(block.body);
      assert.ok(simulation, 'the block is { "simulation": ... }');
      const plant = JSON.parse(read('flows/plant.json'));
      const model = buildModel({ ...plant, simulation });
      assert.ok(model);
    });
  }

  for (const block of blocks.filter((b) => b.tags.by)) {
    it(`${block.where}: ${block.tags.by} runs it`, function () {
      const test = path.join(ROOT, block.tags.by);
      assert.ok(fs.existsSync(test), `${block.tags.by} does not exist`);
      assert.ok(fs.readFileSync(test, 'utf8').includes(block.file), `${block.tags.by} does not read ${block.file}`);
    });
  }

  for (const block of blocks.filter((b) => b.tags.run && !ENVS.some((e) => b.tags[e]))) {
    it(`${block.where}: runs`, async function () {
      this.timeout(SNIPPET_MS + 15000);
      await run(block, {});
    });
  }

  describe('with a broker', function () {
    const mine = blocks.filter((b) => b.tags.run && b.tags.broker);
    let session;
    before(async function () {
      if (!mine.length) this.skip();
      session = new Session('docs-broker');
      await session.startBroker();
    });
    after(() => session && session.cleanup());
    for (const block of mine) {
      it(`${block.where}: runs`, async function () {
        this.timeout(SNIPPET_MS + 15000);
        await run(block, { mqtt: session.server.address().port });
      });
    }
  });

  describe('on a stack: broker, simulator and Node-RED with the case-study flows', function () {
    const mine = blocks.filter((b) => b.tags.run && b.tags.stack);
    let session; let red; const results = [];
    before(async function () {
      if (!mine.length) this.skip();
      this.timeout(120000);
      session = new Session('docs-stack');
      const mqtt = await session.startBroker((packet) => {
        if (packet.topic === RESULT_TOPIC) results.push(JSON.parse(packet.payload.toString()));
      });
      session.sim = await startSimulator({ broker: `mqtt://127.0.0.1:${mqtt}`, plant: path.join(ROOT, 'flows', 'plant.json'), log: () => {} });
      const flows = JSON.parse(read('flows/case-study.json'))
        .map((n) => (n.type === 'mqtt-broker' ? { ...n, broker: '127.0.0.1', port: String(mqtt) } : n));
      red = await session.startRed('docs', flows);
      red.ports = { mqtt, red: Number(new URL(red.url).port) };
    });
    after(() => session && session.cleanup());
    for (const block of mine) {
      it(`${block.where}: runs`, async function () {
        this.timeout(SNIPPET_MS + 15000);
        results.length = 0;
        await run(block, red.ports);
        // A fault sent to the simulator is answered on sim/control/result; none may be refused.
        await sleep(200);
        assert.deepEqual(results.filter((r) => !r.ok), []);
      });
    }
  });
});

