/* The editor's "interlock" sidebar tab: every interlock's lines (free, held by
 * whom, faulted by what and why it may not be cleared yet), its queue and
 * routines, and the plants' devices offline, from GET /sugarshack/state. It
 * asks once a second while the tab is on screen and not at all otherwise.
 * CLEAR posts to /sugarshack/clear as the signed-in editor user; the core
 * decides and its refusal reasons are shown. Alarms not yet acknowledged are
 * listed with an ack that posts to /sugarshack/alarms/ack. Loaded once by
 * interlock.html. */
/* global RED, $ */
(function () {
  'use strict';
  if (window.sugarshackSidebar) return;
  window.sugarshackSidebar = true;

  var POLL_MS = 1000;
  var content = $('<div class="sugarshack-sidebar" style="padding: 8px 10px; overflow-y: auto; height: 100%; box-sizing: border-box;"></div>');
  var body = $('<div class="ss-sb-body"></div>').appendTo(content);
  var footer = $('<div class="ss-sb-at" style="color: #888; font-size: 0.85em; margin-top: 8px;"></div>').appendTo(content);
  var refused = {}; // "interlock/line" -> refusal text, until the line changes state
  var busy = false;

  var COLORS = { free: '#2e7d32', held: '#1565c0', faulted: '#c62828' };

  function secs(ms) { return Math.round(ms / 1000) + ' s'; }
  function clockText(ms) { return new Date(ms).toLocaleTimeString(); }

  function reasonText(r) {
    if (r.kind === 'deviceOffline') return 'device ' + r.device + ' offline';
    if (r.kind === 'lockoutPending') return 'lockout not completed (' + r.actuator + ')';
    if (r.kind === 'offLockout') return r.actuator + ' reads ' + r.position + ', lockout ' + r.lockout;
    if (r.kind === 'stale') return r.actuator + ' feedback stale';
    if (r.kind === 'noFeedback') return r.actuator + ' not heard';
    return r.kind;
  }

  function clearLine(interlock, line) {
    var key = interlock + '/' + line;
    delete refused[key];
    $.ajax({
      url: 'sugarshack/clear', method: 'POST', contentType: 'application/json',
      data: JSON.stringify({ interlock: interlock, lines: [line], reason: 'cleared from the editor sidebar' }),
    }).done(function () { refresh(); }).fail(function (xhr) {
      var answer = xhr.responseJSON || {};
      var reasons = (answer.lines || []).reduce(function (all, l) { return all.concat((l.reasons || []).map(reasonText)); }, []);
      refused[key] = reasons.length ? reasons.join('; ') : (answer.message || ('HTTP ' + xhr.status));
      refresh();
    });
  }

  function ackAlarm(interlock, id) {
    $.ajax({
      url: 'sugarshack/alarms/ack', method: 'POST', contentType: 'application/json',
      data: JSON.stringify({ interlock: interlock, ids: [id] }),
    }).always(function () { refresh(); });
  }

  /** The alarms a person still has to acknowledge (the dashboard lists them all). */
  function alarmRows(il, section) {
    var owed = (il.alarms || []).filter(function (a) { return !a.shelved && /unacknowledged$/.test(a.state); });
    var box = $('<div class="ss-sb-alarms" style="margin-top: 4px;"></div>').appendTo(section);
    $('<b></b>').text('alarms to acknowledge: ').appendTo(box);
    if (!owed.length) box.append(document.createTextNode('none'));
    owed.forEach(function (a) {
      var row = $('<div class="ss-sb-alarm"></div>').attr('data-alarm', a.id).appendTo(box);
      row.text(clockText(a.activeSinceMs) + ' ' + a.text + (a.state === 'returned-unacknowledged' ? ' (back to normal)' : ' '));
      $('<button type="button" class="red-ui-button red-ui-button-small ss-sb-ack" style="margin-left: 4px;">ack</button>')
        .on('click', function () { ackAlarm(il.id, a.id); }).appendTo(row);
    });
  }

  function lineRow(il, line) {
    var state = line.state.state;
    var row = $('<tr class="ss-sb-line"></tr>').attr('data-line', line.name).attr('data-state', state);
    $('<td style="font-weight: bold; padding: 2px 6px 2px 0;"></td>').text(line.name).appendTo(row);
    $('<td class="ss-sb-state" style="color: white; padding: 2px 6px;"></td>').css('background', COLORS[state] || '#777').text(state).appendTo(row);
    var what = $('<td style="padding: 2px 6px;"></td>').appendTo(row);
    if (line.holder) {
      what.text('op ' + line.holder.operation + ' (prio ' + line.holder.priority + ') for ' + secs(line.holder.heldMs));
    } else if (line.fault) {
      what.text(line.fault.cause + (line.fault.operation ? ', op ' + line.fault.operation : '') +
        (line.fault.note ? ': ' + line.fault.note : '') + ' since ' + clockText(line.fault.sinceMs));
      if (line.clearBlockers.length) {
        $('<div class="ss-sb-blockers" style="color: #c62828;"></div>')
          .text('not clearable yet: ' + line.clearBlockers.map(reasonText).join('; ')).appendTo(what);
      }
      var key = il.id + '/' + line.name;
      if (refused[key]) $('<div class="ss-sb-refused" style="color: #c62828;"></div>').text('refused: ' + refused[key]).appendTo(what);
      $('<button type="button" class="red-ui-button red-ui-button-small ss-sb-clear" style="margin-top: 2px;">clear</button>')
        .on('click', function () { clearLine(il.id, line.name); }).appendTo($('<div></div>').appendTo(what));
    }
    if (line.waiting.length) {
      $('<div class="ss-sb-waiting" style="color: #666;"></div>').text('waiting: ' + line.waiting.map(function (o) { return 'op ' + o; }).join(', ')).appendTo(what);
    }
    return row;
  }

  function render(state) {
    body.empty();
    if (!state.interlocks.length) body.text('No interlock is deployed.');
    state.interlocks.forEach(function (il) {
      var section = $('<div class="ss-sb-interlock" style="margin-bottom: 12px;"></div>').attr('data-interlock', il.id).appendTo(body);
      $('<h4 style="margin: 4px 0;"></h4>').text((il.name || il.id) + (il.draining ? ' (deploy waits for operations to finish)' : '')).appendTo(section);
      if (il.state !== 'ready' || !il.lines) {
        $('<div style="color: #c62828;"></div>').text(il.state + (il.failure ? ': ' + il.failure.message : '')).appendTo(section);
        return;
      }
      var table = $('<table class="ss-sb-lines" style="width: 100%; border-collapse: collapse;"></table>').appendTo(section);
      il.lines.forEach(function (line) {
        lineRow(il, line).appendTo(table);
        if (line.state.state !== 'faulted') delete refused[il.id + '/' + line.name];
      });
      alarmRows(il, section);
      var queue = $('<div class="ss-sb-queue" style="margin-top: 6px;"></div>').appendTo(section);
      $('<b></b>').text('queue: ').appendTo(queue);
      queue.append(document.createTextNode(il.queue.length ? il.queue.map(function (q) {
        return 'op ' + q.operation + ' (prio ' + q.priority + ') wants ' + q.resources.join('+') + ', waiting ' + secs(q.waitedMs);
      }).join('; ') : 'empty'));
      if (il.routines.length) {
        var routines = $('<div class="ss-sb-routines" style="margin-top: 4px;"></div>').appendTo(section);
        $('<b></b>').text('routines: ').appendTo(routines);
        routines.append(document.createTextNode(il.routines.map(function (r) {
          return r.id + ' ' + r.state + (r.halted ? ' (halted)' : '') + (r.pending ? ' › ' + (r.pending.phase === 'running' ? 'run ' : 'wait ') + r.pending.operation : '');
        }).join(', ')));
      }
    });
    state.plants.forEach(function (plant) {
      var offline = (plant.devices || []).filter(function (d) { return d.state !== 'online'; });
      var row = $('<div class="ss-sb-devices" style="margin-top: 4px;"></div>').attr('data-plant', plant.id).appendTo(body);
      $('<b></b>').text((plant.name || plant.id) + ': ').appendTo(row);
      row.append(document.createTextNode(offline.length
        ? offline.map(function (d) { return d.device + ' ' + d.state; }).join(', ')
        : (plant.devices ? 'every device online' : plant.state)));
    });
    footer.text('state at ' + clockText(state.atMs));
  }

  function refresh() {
    if (busy) return;
    busy = true;
    $.getJSON('sugarshack/state').done(render).fail(function (xhr) {
      footer.text('GET /sugarshack/state: ' + (xhr.status === 401 || xhr.status === 403 ? 'no permission (sugarshack.read)' : 'HTTP ' + xhr.status));
    }).always(function () { busy = false; });
  }

  function onScreen() {
    return content.is(':visible') && !document.hidden;
  }

  RED.sidebar.addTab({
    id: 'sugarshack-interlock',
    label: 'interlock',
    name: 'Interlock',
    iconClass: 'fa fa-lock',
    content: content,
    enableOnEdit: true,
    onchange: refresh,
  });
  setInterval(function () { if (onScreen()) refresh(); }, POLL_MS);
})();
