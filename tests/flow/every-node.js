'use strict';
// One node of every kind that takes msgs, each wired to its own sinks, on a
// small plant (three lines, a panel of valves and a pump, one level sensor):
// the flow the fuzz and the hostile-input tests throw msgs at. Each test
// gives the plant its operations and routines, and the nodes the settings it
// needs; the rest is this one flow.
const { TAB, sinkNode } = require('./support');

const SINKS = ['mqtt', 'busret', 'ev', 'gcout', 'granted', 'released', 'faulted', 'lockouts', 'cleared', 'cancelled',
  'events', 'rtev', 'waited', 'opout', 'pidout', 'rccout', 'iostate', 'ioact'];

const valve = (id, io, line) => ({ id, type: 'valve', device: 'ctrl-1', io, idle: 0, lockout: 0, resource: line });

/**
 * The plant document: actuators stale after `actuatorStaleMs` with `retries`
 * retries, the level sensor LT-3 stale after `sensorStaleMs`, lines YEL, GRN
 * and RED, and the test's `operations` and `routines`.
 */
function plantDocument({ actuatorStaleMs, retries, sensorStaleMs, operations, routines }) {
  const timing = { noMotionMs: 2000, completionMs: 5000, staleMs: actuatorStaleMs, retries };
  return {
    actuatorTypes: {
      valve: { signal: 'analog', min: 0, max: 100, tolerance: 3, ...timing },
      pump: { signal: 'binary', ...timing },
    },
    devices: [{ id: 'ctrl-1', kind: 'actuator-panel' }, { id: 'station-3', kind: 'sensor-station' }],
    actuators: [
      valve('V101', 1, 'YEL'), valve('V102', 2, 'YEL'), valve('V201', 3, 'GRN'), valve('V501', 5, 'RED'),
      { id: 'P1', type: 'pump', device: 'ctrl-1', io: 1, idle: false, lockout: false, resource: 'YEL' },
    ],
    sensors: [{ id: 'LT-3', device: 'station-3', name: 'volume', staleMs: sensorStaleMs }],
    resources: [{ id: 'YEL' }, { id: 'GRN' }, { id: 'RED' }],
    operations,
    routines,
  };
}

/**
 * The flow on `plant` (persisted interlock `il`, routine `truck`, operation
 * 10). `settings` maps a node's id to the properties it sets apart from these
 * defaults: `{ pid: { smith: 'adaptive' }, wt: { timeout: 5 } }`.
 */
function everyNodeFlow(plant, settings = {}) {
  const n = (id, type, props, wires) => ({ id, z: 'f1', type, ...props, ...settings[id], wires });
  const nodes = [
    n('bus', 'sugarshack-actuators', { plant: 'pl', devices: '' }, [['mqtt'], ['busret'], ['ev']]),
    n('gc', 'sugarshack-group-command', { plant: 'pl', timeout: 0 }, [['gcout']]),
    n('acq', 'sugarshack-acquire', { interlock: 'il', operation: '', priority: '', resources: '', timeout: 0 }, [['granted']]),
    n('rel', 'sugarshack-release', { interlock: 'il', operation: '' }, [['released']]),
    n('flt', 'sugarshack-fault', { interlock: 'il', mode: 'operation', operation: '', resources: '' }, [['faulted'], ['lockouts']]),
    n('stop', 'sugarshack-fault', { interlock: 'il', mode: 'resources', operation: '', resources: '' }, [['faulted'], ['lockouts']]),
    n('clr', 'sugarshack-clear', { interlock: 'il', mode: 'all', resources: '' }, [['cleared']]),
    n('cnl', 'sugarshack-cancel', { interlock: 'il', operation: '' }, [['cancelled']]),
    n('ilev', 'sugarshack-interlock-events', { interlock: 'il' }, [['events']]),
    n('op', 'sugarshack-operation', { interlock: 'il', operation: '10' }, [['opout']]),
    n('rt', 'sugarshack-routine', { interlock: 'il', routine: 'truck', store: 'default' }, [['rtev']]),
    n('wt', 'sugarshack-wait', { plant: 'pl', condition: '`LT-3` >= 100', sensors: 'LT-3', timeout: 60 }, [['waited']]),
    n('pid', 'sugarshack-pid', {
      kp: '2', ti: '10', td: '1', outMin: '0', outMax: '100', action: 'reverse', fallback: '',
      setpoint: '50', mode: 'auto', manual: '', ts: '1', staleS: '0',
      smith: 'off', modelGain: '1', modelTau: '10', deadSamples: '0', alpha: '0.1', h: '3', maxSamples: '400',
      persist: false, store: 'default',
    }, [['pidout']]),
    n('rcc', 'sugarshack-rcc', { controller: '1', thresholdsS: '0.1, 0.2', tsS: '0.05', smooth: true, pollTimeoutS: '' }, [['rccout']]),
    n('io', 'sugarshack-rcc-io', { controllers: '2', initialAction: '0', periodS: '1' }, [['iostate'], ['ioact']]),
  ];
  const unknown = Object.keys(settings).filter((id) => !nodes.some((node) => node.id === id));
  if (unknown.length) throw new Error(`no node ${unknown.join(', ')} in the flow`);
  return [
    TAB,
    { id: 'pl', type: 'sugarshack-plant', name: 'plant', plant },
    {
      id: 'il', type: 'sugarshack-interlock', name: 'lines', plant: 'pl', resources: [], policy: 'greedy',
      queueBound: '', warnQueued: '', warnHeld: '', persist: true, store: 'default',
    },
    ...nodes,
    ...SINKS.map(sinkNode),
  ];
}

module.exports = { SINKS, plantDocument, everyNodeFlow };
