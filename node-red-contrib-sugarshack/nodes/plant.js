'use strict';
const { load } = require('../lib/wasm');
const { plantDocument } = require('../lib/plant');
const { TrackerRuntime } = require('../lib/tracker-runtime');
const { serveStats } = require('../lib/stats');

module.exports = function (RED) {
  const { Tracker } = load();
  serveStats(RED);

  function PlantNode(props) {
    RED.nodes.createNode(this, props);
    const node = this;
    node.name = props.name;
    let plant = null;
    let plantError = null;
    try {
      plant = plantDocument(props.plant);
    } catch (err) {
      plantError = err;
    }
    node.runtime = new TrackerRuntime({ owner: node, Tracker, plant });
    node.runtime.start(plantError);

    node.on('close', (removed, done) => {
      node.runtime.close();
      done();
    });
  }

  RED.nodes.registerType('sugarshack-plant', PlantNode);
};
