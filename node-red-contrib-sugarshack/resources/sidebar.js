/* The editor's "interlock" sidebar tab: every interlock's lines (free, held by
 * whom, faulted by what and why it may not be cleared yet), its queue and
 * routines, and the plants' devices offline, from GET /sugarshack/state. It
 * asks once a second while the tab is on screen and not at all otherwise.
 * CLEAR posts to /sugarshack/clear as the signed-in editor user; the core
 * decides and its refusal reasons are shown. Alarms not yet acknowledged are
 * listed with an ack that posts to /sugarshack/alarms/ack. Loaded once by
 * interlock.html. Its texts are the interlock set's catalog's, in the editor's
 * language (nodes/locales/<lang>/interlock.json, sugarshack-interlock.sidebar). */
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
  var NS = 'node-red-contrib-sugarshack/interlock:sugarshack-interlock.';

  function t(key, subs) { return RED._(NS + key, subs); }

  function secs(ms) { return Math.round(ms / 1000) + ' s'; }
  function clockText(ms) { return new Date(ms).toLocaleTimeString(); }

  function reasonText(r) {
    if (r.kind === 'deviceOffline') return t('sidebar.deviceOffline', { device: r.device });
    if (r.kind === 'lockoutPending') return t('sidebar.lockoutPending', { actuator: r.actuator });
    if (r.kind === 'offLockout') return t('sidebar.offLockout', { actuator: r.actuator, position: r.position, lockout: r.lockout });
    if (r.kind === 'stale') return t('sidebar.stale', { actuator: r.actuator });
    if (r.kind === 'noFeedback') return t('sidebar.noFeedback', { actuator: r.actuator });
    return r.kind;
  }

  function clearLine(interlock, line) {
    var key = interlock + '/' + line;
    delete refused[key];
    $.ajax({
      url: 'sugarshack/clear', method: 'POST', contentType: 'application/json',
      data: JSON.stringify({ interlock: interlock, lines: [line], reason: t('sidebar.clearReason') }),
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
    $('<b></b>').text(t('sidebar.alarmsToAck')).appendTo(box);
    if (!owed.length) box.append(document.createTextNode(t('sidebar.none')));
    owed.forEach(function (a) {
      var row = $('<div class="ss-sb-alarm"></div>').attr('data-alarm', a.id).appendTo(box);
      row.text(clockText(a.activeSinceMs) + ' ' + a.text + (a.state === 'returned-unacknowledged' ? ' ' + t('sidebar.backToNormal') : ' '));
      $('<button type="button" class="red-ui-button red-ui-button-small ss-sb-ack" style="margin-left: 4px;"></button>').text(t('sidebar.ack'))
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
      what.text(t('sidebar.holder', { operation: line.holder.operation, priority: line.holder.priority, time: secs(line.holder.heldMs) }));
    } else if (line.fault) {
      var cause = line.fault.cause + (line.fault.operation ? ', ' + t('sidebar.op', { operation: line.fault.operation }) : '') +
        (line.fault.note ? ': ' + line.fault.note : '');
      what.text(t('sidebar.faultSince', { cause: cause, time: clockText(line.fault.sinceMs) }));
      if (line.clearBlockers.length) {
        $('<div class="ss-sb-blockers" style="color: #c62828;"></div>')
          .text(t('sidebar.notClearable', { reasons: line.clearBlockers.map(reasonText).join('; ') })).appendTo(what);
      }
      var key = il.id + '/' + line.name;
      if (refused[key]) $('<div class="ss-sb-refused" style="color: #c62828;"></div>').text(t('sidebar.refused', { reason: refused[key] })).appendTo(what);
      $('<button type="button" class="red-ui-button red-ui-button-small ss-sb-clear" style="margin-top: 2px;"></button>').text(t('sidebar.clear'))
        .on('click', function () { clearLine(il.id, line.name); }).appendTo($('<div></div>').appendTo(what));
    }
    if (line.waiting.length) {
      $('<div class="ss-sb-waiting" style="color: #666;"></div>').text(t('sidebar.waiting', { operations: line.waiting.map(function (o) { return t('sidebar.op', { operation: o }); }).join(', ') })).appendTo(what);
    }
    return row;
  }

  /** Which instance acts, since when, its lease, etcd's members and the failovers (a hot-standby cluster only). */
  function clusterRows(c) {
    var box = $('<div class="ss-sb-cluster" style="margin-bottom: 8px; padding: 4px 6px; border-left: 4px solid;"></div>').attr('data-role', c.role).appendTo(body);
    box.css('border-color', c.role === 'active' ? COLORS.free : c.role === 'standby' ? '#777' : COLORS.faulted);
    var since = clockText(c.sinceMs);
    var head;
    if (c.role === 'active' && c.lease) {
      head = t('sidebar.clusterActive', {
        cluster: c.name, instance: c.instance, time: since, token: c.token, ttl: c.lease.ttlS, left: (c.lease.validForMs / 1000).toFixed(1),
      });
    } else if (c.role === 'standby') {
      head = t('sidebar.clusterStandby', { cluster: c.name, instance: c.instance, time: since, leader: c.leader ? c.leader.instance : '?' });
    } else {
      head = t('sidebar.clusterOther', { cluster: c.name, instance: c.instance, role: c.role, time: since });
    }
    $('<div class="ss-sb-cluster-role"></div>').text(head).appendTo(box);
    var down = c.etcd.filter(function (m) { return !m.healthy; }).map(function (m) { return m.endpoint; });
    var last = c.lastFailover ? t('sidebar.clusterLast', { from: c.lastFailover.from, to: c.lastFailover.to, time: clockText(c.lastFailover.atMs) }) : '';
    $('<div class="ss-sb-cluster-health"></div>').text(t('sidebar.clusterHealth', {
      healthy: c.etcd.length - down.length, total: c.etcd.length, down: down.length ? t('sidebar.clusterDown', { members: down.join(', ') }) : '', failovers: c.failovers, last: last,
    })).appendTo(box);
  }

  function render(state) {
    body.empty();
    if (state.cluster) clusterRows(state.cluster);
    if (!state.interlocks.length) body.text(t('sidebar.noInterlock'));
    state.interlocks.forEach(function (il) {
      var section = $('<div class="ss-sb-interlock" style="margin-bottom: 12px;"></div>').attr('data-interlock', il.id).appendTo(body);
      $('<h4 style="margin: 4px 0;"></h4>').text((il.name || il.id) + (il.draining ? ' ' + t('sidebar.draining') : '')).appendTo(section);
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
      $('<b></b>').text(t('sidebar.queue')).appendTo(queue);
      queue.append(document.createTextNode(il.queue.length ? il.queue.map(function (q) {
        return t('sidebar.queued', { operation: q.operation, priority: q.priority, lines: q.resources.join('+'), time: secs(q.waitedMs) });
      }).join('; ') : t('sidebar.empty')));
      if (il.routines.length) {
        var routines = $('<div class="ss-sb-routines" style="margin-top: 4px;"></div>').appendTo(section);
        $('<b></b>').text(t('sidebar.routines')).appendTo(routines);
        routines.append(document.createTextNode(il.routines.map(function (r) {
          var pending = r.pending ? ' › ' + t(r.pending.phase === 'running' ? 'sidebar.routineRun' : 'sidebar.routineWait', { operation: r.pending.operation }) : '';
          return r.id + ' ' + r.state + (r.halted ? ' ' + t('sidebar.halted') : '') + pending;
        }).join(', ')));
      }
    });
    state.plants.forEach(function (plant) {
      var offline = (plant.devices || []).filter(function (d) { return d.state !== 'online'; });
      var row = $('<div class="ss-sb-devices" style="margin-top: 4px;"></div>').attr('data-plant', plant.id).appendTo(body);
      $('<b></b>').text((plant.name || plant.id) + ': ').appendTo(row);
      row.append(document.createTextNode(offline.length
        ? offline.map(function (d) { return d.device + ' ' + d.state; }).join(', ')
        : (plant.devices ? t('sidebar.allOnline') : plant.state)));
    });
    footer.text(t('sidebar.stateAt', { time: clockText(state.atMs) }));
  }

  function refresh() {
    if (busy) return;
    busy = true;
    $.getJSON('sugarshack/state').done(render).fail(function (xhr) {
      footer.text('GET /sugarshack/state: ' + (xhr.status === 401 || xhr.status === 403 ? t('sidebar.noPermission') : 'HTTP ' + xhr.status));
    }).always(function () { busy = false; });
  }

  function onScreen() {
    return content.is(':visible') && !document.hidden;
  }

  RED.sidebar.addTab({
    id: 'sugarshack-interlock',
    label: t('sidebar.tabLabel'),
    name: t('sidebar.tabName'),
    iconClass: 'fa fa-lock',
    content: content,
    enableOnEdit: true,
    onchange: refresh,
  });
  setInterval(function () { if (onScreen()) refresh(); }, POLL_MS);
})();
