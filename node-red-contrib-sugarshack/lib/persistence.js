'use strict';
// Keeps the interlock snapshot in global context, so latched faults survive a
// redeploy (any store) or a restart (a persistent store such as localfilesystem).

function contextKey(configNodeId) {
  return `sugarshack-interlock:${configNodeId}`;
}

class Persistence {
  /** store: a context store name; "default" or empty means the default store. */
  constructor(globalContext, configNodeId, store) {
    this.context = globalContext;
    this.key = contextKey(configNodeId);
    this.store = store && store !== 'default' ? store : undefined;
    this.writing = null; // promise of the write in flight
    this.next = undefined; // newest snapshot not yet written
  }

  load() {
    return new Promise((resolve, reject) => {
      this.context.get(this.key, this.store, (err, value) => (err ? reject(err) : resolve(value)));
    });
  }

  /** Queues a write; writes never overlap and only the newest waiting snapshot is written. */
  save(snapshot) {
    this.next = snapshot;
    if (!this.writing) this.writing = this.drain();
    return this.writing;
  }

  async drain() {
    try {
      while (this.next !== undefined) {
        const value = this.next;
        this.next = undefined;
        await new Promise((resolve, reject) => {
          this.context.set(this.key, value, this.store, (err) => (err ? reject(err) : resolve()));
        });
      }
    } finally {
      this.writing = null;
    }
  }

  /** Resolves when every queued write has completed. */
  flush() {
    return this.writing || Promise.resolve();
  }
}

module.exports = { Persistence, contextKey };
