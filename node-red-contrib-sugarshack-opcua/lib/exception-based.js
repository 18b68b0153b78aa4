'use strict';
// Every variable of a plant changes only by exception (model.js sets it when
// the palette says it changed), so a sampling timer per monitored item would
// only read an unchanged value again: a client subscribing to a large plant
// at 10 ms would keep the event loop busy doing nothing. node-opcua samples a
// Value item unless its client asks for 0; this makes every Value item on a
// namespace of ours exception-based, its revised sampling interval the window
// over which changes are coalesced (at most one notification per window, the
// latest value), as OPC 10000-4 5.12.1.2 lets a server with exception-based
// data do. node-opcua's own nodes (the Server object's) are left as they are.
const { MonitoredItem, AttributeIds } = require('node-opcua');

const namespaces = new Set(); // namespace URIs served by a plant
let installed = false;

/** Makes Value items on nodes of namespace `uri` exception-based; false when this node-opcua cannot be taught it. */
function exceptionBased(uri) {
  namespaces.add(uri);
  if (installed) return true;
  const proto = MonitoredItem && MonitoredItem.prototype;
  if (!proto || typeof proto.__start_sampling !== 'function' || typeof proto._on_value_changed_exception_based !== 'function') return false;
  const start = proto.__start_sampling;
  proto.__start_sampling = function (recordInitialValue) {
    const node = this.node;
    if (node && this.itemToMonitor.attributeId === AttributeIds.Value && node.minimumSamplingInterval === 0
      && namespaces.has(node.addressSpace.getNamespaceUri(node.nodeId.namespace))) {
      this._exceptionBased = true;
    }
    return start.call(this, recordInitialValue);
  };
  installed = true;
  return true;
}

module.exports = { exceptionBased };
