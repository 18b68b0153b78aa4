'use strict';
const { plantDocument } = require('../lib/plant');
const { PlantRuntime } = require('../lib/plant-runtime');
const { serveStats } = require('../lib/stats');
const { paletteOf, settingsKey } = require('../lib/lifecycle');

module.exports = function (RED) {
  paletteOf(RED);
  serveStats(RED);

  function PlantNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    node.name = props.name;
    const palette = paletteOf(RED);
    const settings = { plant: null, error: null };
    try {
      settings.plant = plantDocument(props.plant);
    } catch (err) {
      settings.error = err;
    }
    const key = settingsKey({ plant: settings.plant, error: settings.error ? settings.error.message : null });
    const runtime = palette.runtimeFor(node.id, key, settings, () => new PlantRuntime({ RED, id: node.id, settings }));
    runtime.attach(node);
    node.runtime = runtime;
    if (!runtime.started) {
      runtime.started = true;
      runtime.start();
    } else {
      runtime.refreshStatus();
    }

    node.on('close', (removed, done) => {
      palette.detach(runtime, node, removed).then(() => done(), (err) => {
        node.error(err);
        done();
      });
    });
  }

  RED.nodes.registerType('sugarshack-plant', PlantNode);
};
