/* Shared editor helpers for the sugarshack nodes. Loaded by several node
 * templates, so it defines itself only once. */
/* global RED, $ */
(function () {
  'use strict';
  if (window.sugarshackEditor) return;

  function parseNames(text) {
    return String(text || '').split(',').map(function (s) { return s.trim(); }).filter(Boolean);
  }

  function configNode(configId) {
    return configId && configId !== '_ADD_' ? RED.nodes.node(configId) : null;
  }

  function resourceNames(configId) {
    var config = configNode(configId);
    if (!config || !Array.isArray(config.resources)) return [];
    return config.resources.map(function (r) { return r.name; }).filter(Boolean);
  }

  /** The document of a plant config node: an object, or text as typed (null while it does not parse). */
  function plantOf(configId) {
    var config = configNode(configId);
    var plant = config && config.plant;
    if (typeof plant === 'string') {
      try { plant = JSON.parse(plant); } catch (e) { return null; }
    }
    return plant && typeof plant === 'object' ? plant : null;
  }

  /** The entries of a plant document's list (`devices`, `sensors`, `operations`...) that have an id. */
  function entriesOf(plant, list) {
    var entries = plant && Array.isArray(plant[list]) ? plant[list] : [];
    return entries.filter(function (e) { return e && typeof e.id === 'string' && e.id; });
  }

  function idsOf(plant, list) {
    return entriesOf(plant, list).map(function (e) { return e.id; });
  }

  /** The device ids of a plant config node. */
  function deviceNames(configId) {
    return idsOf(plantOf(configId), 'devices');
  }

  /** The sensor ids of a plant config node. */
  function sensorNames(configId) {
    return idsOf(plantOf(configId), 'sensors');
  }

  /** The document of the plant an interlock config node is bound to. */
  function plantOfInterlock(configId) {
    var config = configNode(configId);
    return config ? plantOf(config.plant) : null;
  }

  /** The operations of an interlock's plant, each shown with its description. */
  function operationChoices(configId) {
    return entriesOf(plantOfInterlock(configId), 'operations').map(function (op) {
      return { value: op.id, label: typeof op.description === 'string' && op.description ? op.id + ': ' + op.description : op.id };
    });
  }

  /** The routines of an interlock's plant. */
  function routineChoices(configId) {
    return idsOf(plantOfInterlock(configId), 'routines').map(function (id) { return { value: id, label: id }; });
  }

  /** Toggle buttons for the names `namesOf(configId)` gives, kept in step with a comma-separated input. */
  function namePicker(inputSelector, configSelector, boxSelector, namesOf) {
    var input = $(inputSelector);
    var box = $(boxSelector);
    function render() {
      box.empty();
      var chosen = parseNames(input.val());
      namesOf($(configSelector).val()).forEach(function (name) {
        $('<button type="button" class="red-ui-button red-ui-button-small"></button>')
          .text(name)
          .css({ margin: '0 4px 4px 0' })
          .toggleClass('selected', chosen.indexOf(name) !== -1)
          .on('click', function () {
            var names = parseNames(input.val());
            var at = names.indexOf(name);
            if (at === -1) names.push(name); else names.splice(at, 1);
            input.val(names.join(',')).trigger('change');
          })
          .appendTo(box);
      });
    }
    input.on('change keyup', render);
    $(configSelector).on('change', render);
    render();
  }

  /** Toggle buttons for the chosen interlock's resources. */
  function resourcePicker(inputSelector, configSelector, boxSelector) {
    namePicker(inputSelector, configSelector, boxSelector, resourceNames);
  }

  /** Toggle buttons for the chosen plant's devices. */
  function devicePicker(inputSelector, configSelector, boxSelector) {
    namePicker(inputSelector, configSelector, boxSelector, deviceNames);
  }

  /** Toggle buttons for the chosen plant's sensors. */
  function sensorPicker(inputSelector, configSelector, boxSelector) {
    namePicker(inputSelector, configSelector, boxSelector, sensorNames);
  }

  /**
   * A typedInput on a text input naming one entry of the plant document: type `listed` ({ value,
   * label, icon }) lists the entries `choicesOf(configId)` gives ({ value, label }) for the config
   * node chosen in `configSelector`; type `str` takes any id typed (the plant not chosen or not
   * saved yet). A value the list has, or none, opens on the list; another opens typed. With
   * `typeField` (a hidden input), the value may also be read for each msg from SOURCES, its type kept there.
   */
  function plantChoice(inputSelector, configSelector, choicesOf, listed, typeField) {
    var input = $(inputSelector);
    var sources = typeField ? SOURCES : [];
    var choices = [];
    function read() {
      choices = choicesOf($(configSelector).val());
      return (choices.length ? [$.extend({ options: choices }, listed), 'str'] : ['str']).concat(sources);
    }
    function typeOf(value, type) {
      if (sources.indexOf(type) !== -1) return type;
      var inList = choices.some(function (c) { return c.value === value; });
      return choices.length && (inList || !value) ? listed.value : 'str';
    }
    var value = input.val();
    var types = read();
    var type = typeOf(value, typeField && $(typeField).val());
    var options = { types: types, default: type };
    if (typeField) {
      $(typeField).val(type);
      options.typeField = typeField;
    }
    input.typedInput(options);
    $(configSelector).on('change', function () {
      // The editor fires this once it fills the config list; an unchanged list keeps an open menu.
      var shown = JSON.stringify(choices);
      var next = read();
      if (JSON.stringify(choices) === shown) return;
      var before = input.typedInput('value');
      var was = input.typedInput('type');
      input.typedInput('types', next);
      input.typedInput('type', typeOf(before, was));
      if (typeOf(before, was) !== listed.value || before) input.typedInput('value', before);
    });
  }

  /** The chosen interlock's plant's operations, or any id typed (or, with `typeField`, read for each msg). */
  function operationChoice(inputSelector, configSelector, listed, typeField) {
    plantChoice(inputSelector, configSelector, operationChoices, listed, typeField);
  }

  /** The chosen interlock's plant's routines, or any id typed. */
  function routineChoice(inputSelector, configSelector, listed) {
    plantChoice(inputSelector, configSelector, routineChoices, listed);
  }

  function blank(v) { return v === undefined || v === null || String(v).trim() === ''; }

  /** "1000, 2000" (ms) -> "1, 2" (s). */
  function msToSeconds(v) {
    return parseNames(v).map(function (s) { return String(Number(s) / 1000); }).join(', ');
  }

  /**
   * Flows saved before durations were in seconds carry them in ms under the old
   * name: shown in seconds in the dialog's `name` field, saved under the new name.
   */
  function migrateMs(node, name, legacyMs) {
    if (blank(node[name]) && !blank(node[legacyMs])) $('#node-input-' + name).val(msToSeconds(node[legacyMs]));
  }

  // Where a node's value may come from besides its literal, read for each msg (msg.<field> still comes first).
  var SOURCES = ['msg', 'flow', 'global', 'env', 'jsonata'];

  /**
   * A typedInput on each `[name, literalType]` of the node's dialog, its type
   * kept in the hidden `#node-input-<name>Type`; a flow saved before the types has
   * none, so its value is the literal it was.
   */
  function valueSources(node, fields) {
    fields.forEach(function (field) {
      var type = node[field[0] + 'Type'] || field[1];
      $('#node-input-' + field[0] + 'Type').val(type);
      $('#node-input-' + field[0]).typedInput({ default: field[1], types: [field[1]].concat(SOURCES), typeField: '#node-input-' + field[0] + 'Type' });
    });
  }

  var COLOR = '#D9A55B';

  /**
   * A node that acts on one operation of an interlock, named in the node or
   * the msg (release: its lines; cancel: its waiting request). The two are
   * alike but for the verb, which names the type, icon, label and texts
   * (`sugarshack-<verb>.paletteLabel`, `.label.interlock`, `.label.operation`):
   * this registers the type and adds its dialog.
   */
  function operationNode(verb) {
    var type = 'sugarshack-' + verb;
    var text = function (key) { return '<span data-i18n="' + type + '.' + key + '"></span>'; };
    $('<script type="text/html"></script>').attr('data-template-name', type).text([
      '<div class="form-row">',
      '  <label for="node-input-interlock"><i class="fa fa-lock"></i> ' + text('label.interlock') + '</label>',
      '  <input type="text" id="node-input-interlock">',
      '</div>',
      '<div class="form-row">',
      '  <label for="node-input-operation"><i class="fa fa-cog"></i> ' + text('label.operation') + '</label>',
      '  <input type="text" id="node-input-operation" data-i18n="[placeholder]' + type + '.placeholder.operation">',
      '  <input type="hidden" id="node-input-operationType">',
      '</div>',
      '<div class="form-row">',
      '  <label for="node-input-name"><i class="fa fa-tag"></i> <span data-i18n="node-red:common.label.name"></span></label>',
      '  <input type="text" id="node-input-name">',
      '</div>',
    ].join('\n')).appendTo('body');
    RED.nodes.registerType(type, {
      category: 'sugarshack',
      color: COLOR,
      paletteLabel: function () { return this._(type + '.paletteLabel'); },
      icon: verb + '.svg',
      inputs: 1,
      outputs: 1,
      defaults: {
        name: { value: '' },
        interlock: { value: '', type: 'sugarshack-interlock', required: true },
        operation: { value: '' },
        operationType: { value: 'str' },
      },
      label: function () {
        return this.name || (this.operation ? this._(type + '.nodeLabel.operation', { operation: this.operation }) : this._(type + '.paletteLabel'));
      },
      labelStyle: function () { return this.name ? 'node_label_italic' : ''; },
      oneditprepare: function () { valueSources(this, [['operation', 'str']]); },
    });
  }

  window.sugarshackEditor = {
    resourcePicker: resourcePicker, devicePicker: devicePicker, sensorPicker: sensorPicker,
    operationChoice: operationChoice, routineChoice: routineChoice, parseNames: parseNames, migrateMs: migrateMs, operationNode: operationNode, valueSources: valueSources, color: COLOR,
  };
})();
