/* Shared editor helpers for the sugarshack nodes. Loaded by several node
 * templates, so it defines itself only once. */
/* global RED, $ */
(function () {
  'use strict';
  if (window.sugarshackEditor) return;

  function parseNames(text) {
    return String(text || '').split(',').map(function (s) { return s.trim(); }).filter(Boolean);
  }

  function resourceNames(configId) {
    var config = configId && configId !== '_ADD_' ? RED.nodes.node(configId) : null;
    if (!config || !Array.isArray(config.resources)) return [];
    return config.resources.map(function (r) { return r.name; }).filter(Boolean);
  }

  /** Toggle buttons for the chosen interlock's resources, kept in step with a comma-separated input. */
  function resourcePicker(inputSelector, configSelector, boxSelector) {
    var input = $(inputSelector);
    var box = $(boxSelector);
    function render() {
      box.empty();
      var chosen = parseNames(input.val());
      resourceNames($(configSelector).val()).forEach(function (name) {
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

  window.sugarshackEditor = { resourcePicker: resourcePicker, parseNames: parseNames, color: '#D9A55B' };
})();
