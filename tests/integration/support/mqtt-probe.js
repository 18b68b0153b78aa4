'use strict';
// An observer MQTT client for tests: records what it receives and waits for
// the first message that matches.
//
//   const probe = await connectProbe(broker.url, ['ctrl-1/#']);
//   const msg = await probe.waitFor('ctrl-1/state', (m) => m.json.valve['1'] > 97, 5000);
//   await probe.publish('ctrl-1/valve/1/command', '100');
const mqtt = require('mqtt');

// MQTT wildcard match: '+' one level, '#' the rest.
function topicMatches(filter, topic) {
  const f = filter.split('/');
  const t = topic.split('/');
  for (let i = 0; i < f.length; i++) {
    if (f[i] === '#') return true;
    if (i >= t.length || (f[i] !== '+' && f[i] !== t[i])) return false;
  }
  return f.length === t.length;
}

function decode(topic, payload, packet) {
  const text = payload.toString();
  let json;
  try {
    json = JSON.parse(text);
  } catch {
    json = undefined;
  }
  return { topic, text, json, retain: Boolean(packet.retain), at: Date.now() };
}

async function connectProbe(url, topics = ['#'], options = {}) {
  const client = await mqtt.connectAsync(url, { reconnectPeriod: 200, ...options });
  const messages = [];
  const waiters = new Set();
  client.on('message', (topic, payload, packet) => {
    const msg = decode(topic, payload, packet);
    messages.push(msg);
    for (const w of [...waiters]) {
      if (topicMatches(w.filter, topic) && w.test(msg)) {
        waiters.delete(w);
        clearTimeout(w.timer);
        w.resolve(msg);
      }
    }
  });
  if (topics.length) await client.subscribeAsync(topics, { qos: 1 });

  return {
    client,
    messages,
    // Next message (from now on, unless `fromHistory`) on `filter` that passes `test`.
    waitFor(filter, test = () => true, timeoutMs = 5000, { fromHistory = false } = {}) {
      if (fromHistory) {
        const hit = messages.find((m) => topicMatches(filter, m.topic) && test(m));
        if (hit) return Promise.resolve(hit);
      }
      return new Promise((resolve, reject) => {
        const w = { filter, test, resolve };
        w.timer = setTimeout(() => {
          waiters.delete(w);
          const seen = messages.filter((m) => topicMatches(filter, m.topic)).slice(-3).map((m) => m.text);
          reject(new Error(`no matching message on ${filter} within ${timeoutMs} ms; last seen: ${JSON.stringify(seen)}`));
        }, timeoutMs);
        waiters.add(w);
      });
    },
    // Messages on `filter` received so far.
    on(filter) {
      return messages.filter((m) => topicMatches(filter, m.topic));
    },
    clear() {
      messages.length = 0;
    },
    publish(topic, payload, opts = {}) {
      return client.publishAsync(topic, typeof payload === 'string' ? payload : JSON.stringify(payload), { qos: 1, ...opts });
    },
    end() {
      for (const w of waiters) clearTimeout(w.timer);
      waiters.clear();
      return client.endAsync(true);
    },
  };
}

module.exports = { connectProbe, topicMatches };
