'use strict';
// Follows the tutorial docs/tutorial/own-plant.md as a reader would, taking
// everything from the page: its plant document (the `json plant` block, saved
// under the name its commands use), its commands (the `sh` blocks this test
// runs), the mistake it describes and the words the check answers with, and
// the buttons it says to click, in order. Checked, npm start on the plant,
// the operation run on the simulator until it completes; then the stuck
// valve, the operation faulting with the message the page quotes, and the
// clear.
const assert = require('node:assert/strict');
const fs = require('fs');
const os = require('os');
const path = require('path');
const { spawnSync } = require('child_process');
const { read, parse } = require('../../scripts/docs/markdown');
const { run } = require('../../scripts/docs/snippets');
const { startNpmStart, until, ROOT } = require('./support/npm-start');

const PAGE = 'docs/tutorial/own-plant.md';
const { fences, prose } = parse(read(PAGE));
const text = prose.join('\n');
const commands = fences.filter((f) => f.lang === 'sh' && f.tags.by === 'tests/integration/tutorial.spec.js').map((f) => ({ ...f, where: `${PAGE}:${f.line}` }));
const plantBlock = fences.find((f) => f.lang === 'json' && f.tags.plant);
/** The buttons the page says to click, in its order. */
const clicks = [...text.matchAll(/click\s+\*\*([^*]+)\*\*/g)].map((m) => m[1]);
const command = (re) => {
  const found = commands.find((c) => re.test(c.body.trim()));
  assert.ok(found, `${PAGE} has a command matching ${re}`);
  return found.body.trim();
};
/** `npm start -- <args>` as the page writes it: its arguments. */
const argsOf = (line) => line.replace(/^npm start -- /, '').split(/\s+/);

describe(`the tutorial ${PAGE}, followed from the page`, function () {
  this.timeout(15 * 60 * 1000);
  let dir; let stack;
  const plantFile = () => argsOf(command(/^npm start -- --plant \S+$/))[1];

  before(function () {
    dir = fs.mkdtempSync(path.join(os.tmpdir(), 'sugarshack-tutorial-'));
    fs.writeFileSync(path.join(dir, plantFile()), `${plantBlock.body}\n`);
  });

  after(async function () {
    if (stack && this.currentTest && this.currentTest.state === 'failed') console.log(stack.output.slice(-5000));
    if (stack) await stack.stop();
    fs.rmSync(dir, { recursive: true, force: true });
  });

  /** `npm start -- <args>` typed in the folder that holds the plant document (npm told where the repository is). */
  const npmStart = (args) => spawnSync('npm', ['--prefix', ROOT, 'start', '--', ...args], { cwd: dir, encoding: 'utf8', timeout: 600000 });

  it('2. the check passes with the words the page shows, and names the mistake the page describes', function () {
    const checked = npmStart(argsOf(command(/--check$/)));
    assert.equal(checked.status, 0, checked.stdout + checked.stderr);
    const shown = fences.find((f) => f.lang === 'text' && /^check: /.test(f.body)).body.trim();
    assert.ok(checked.stdout.includes(shown), `the check says "${shown}":\n${checked.stdout}`);
    // The same plant named by the environment instead.
    const byEnv = spawnSync('npm', ['--prefix', ROOT, 'start', '--', '--check'], { cwd: dir, encoding: 'utf8', timeout: 600000, env: { ...process.env, SUGARSHACK_PLANT: plantFile() } });
    assert.ok(byEnv.status === 0 && byEnv.stdout.includes(shown), `SUGARSHACK_PLANT=${plantFile()}: ${byEnv.stdout}${byEnv.stderr}`);

    const [, actuator, device] = /give (\S+) the device\s+`([^`]+)`/.exec(text);
    const [, said] = /the check says `([^`]+)`/.exec(text);
    const plant = JSON.parse(plantBlock.body);
    plant.actuators.find((a) => a.id === actuator).device = device;
    const wrong = 'wrong-plant.json';
    fs.writeFileSync(path.join(dir, wrong), JSON.stringify(plant));
    const refused = npmStart(['--plant', wrong, '--check']);
    assert.equal(refused.status, 1, 'exit status 1');
    assert.ok(refused.stderr.includes(said), `it says "${said}":\n${refused.stderr}`);
  });

  it('3-4. npm start -- --plant runs the plant on the simulator; the operation\'s button runs it to completion', async function () {
    stack = await startNpmStart({ args: argsOf(command(/^npm start -- --plant \S+$/)), cwd: dir });
    assert.match(stack.output, /flows: starter flows made from/);
    const flows = await stack.flows();
    const button = (name) => {
      const n = flows.find((x) => x.type === 'inject' && x.name === name);
      assert.ok(n, `a button '${name}' in the starter flows`);
      return n.id;
    };
    const completed = flows.find((n) => n.type === 'debug' && n.name === 'completed').id;
    const operation = JSON.parse(plantBlock.body).operations[0];
    const line = async () => (await stack.state()).interlocks[0].lines.find((l) => l.name === operation.resources[0]);

    assert.ok(clicks.length >= 1, 'the page names the buttons to click');
    const started = Date.now();
    await stack.click(button(clicks[0]));
    await until(async () => (await line()).state.state === 'held', 'the line held by the operation', 10000);
    const [done] = await until(() => stack.debugOf(completed).length && stack.debugOf(completed), 'the operation to complete', 120000);
    assert.equal(done.operation.id, operation.id);
    const tookS = Math.round((Date.now() - started) / 1000);
    const [, saysS] = /About (\d+) s after the click\s+the pump has stopped/.exec(text);
    assert.ok(Math.abs(tookS - Number(saysS)) <= 6, `it took ${tookS} s; the page says about ${saysS} s`);
    assert.equal((await line()).state.state, 'free');
    const state = await stack.state();
    assert.deepEqual(state.plants[0].sensors.map((s) => s.unit), ['L', 'L']);

    // The page's curl, on this stack's port: the same state, the line free again.
    const curl = commands.find((c) => /^curl /.test(c.body.trim()));
    const out = await run(curl, { red: stack.port });
    assert.equal(JSON.parse(out).interlocks[0].lines[0].state.state, 'free');
  });

  it('5. the stuck valve faults the operation with the page\'s words and locks the line out; the clears free it', async function () {
    const flows = await stack.flows();
    const press = (name) => stack.click(flows.find((x) => x.type === 'inject' && x.name === name).id);
    const line = async () => (await stack.state()).interlocks[0].lines[0];
    const [, stuck, runAgain, repair, clear] = clicks;
    assert.deepEqual([stuck, runAgain, repair, clear].map((c) => typeof c), ['string', 'string', 'string', 'string'], `the page's buttons: ${clicks.join(', ')}`);
    await press(stuck);
    await new Promise((resolve) => setTimeout(resolve, 1000)); // the simulator takes it over MQTT
    const clicked = Date.now();
    await press(runAgain);
    const faulted = await until(async () => { const l = await line(); return l.state.state === 'faulted' && l; }, 'the line faulted', 40000);
    const [, quoted] = /faults and refusals\* says\s+`([^`]+)`/.exec(text);
    assert.ok(faulted.fault.note.includes(quoted), `the fault says "${quoted}": ${faulted.fault.note}`);
    const faultsTab = flows.find((n) => n.type === 'tab' && n.label === 'Faults and clearing').id;
    const shown = flows.find((n) => n.type === 'debug' && n.name === 'faults and refusals' && n.z === faultsTab).id;
    await until(() => stack.debugOf(shown).some((m) => m.includes(quoted)), `'faults and refusals' on the faults tab showing "${quoted}"`, 5000);
    const [, aboutS] = /about (\d+) s\s+after the click the operation faults/.exec(text);
    assert.ok(Math.abs((Date.now() - clicked) / 1000 - Number(aboutS)) <= 4, `faulted ${Date.now() - clicked} ms after the click; the page says about ${aboutS} s`);
    await press(repair);
    await until(async () => (await line()).clearBlockers.length === 0, 'the line clearable', 20000);
    await press(clear);
    await until(async () => (await line()).state.state === 'free', 'the line free again', 20000);
    assert.deepEqual(stack.errorsSince(0), [], 'nothing logged as an error');
  });
});
