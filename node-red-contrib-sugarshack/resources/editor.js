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

  /** The device ids of a plant config node (its document is an object, or text while it does not parse). */
  function deviceNames(configId) {
    var config = configNode(configId);
    var plant = config && config.plant;
    if (typeof plant === 'string') {
      try { plant = JSON.parse(plant); } catch (e) { return []; }
    }
    if (!plant || !Array.isArray(plant.devices)) return [];
    return plant.devices.map(function (d) { return d && d.id; }).filter(Boolean);
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
      },
      label: function () {
        return this.name || (this.operation ? this._(type + '.nodeLabel.operation', { operation: this.operation }) : this._(type + '.paletteLabel'));
      },
      labelStyle: function () { return this.name ? 'node_label_italic' : ''; },
    });
  }

  window.sugarshackEditor = {
    resourcePicker: resourcePicker, devicePicker: devicePicker, parseNames: parseNames, migrateMs: migrateMs, operationNode: operationNode, color: COLOR,
  };
})();
