#!/usr/bin/env python3
"""An independent OPC UA client for the tests: Python's asyncua (not node-opcua),
driven by the test over stdin/stdout, one JSON request per line, one JSON
answer per line ({"id", "result"} or {"id", "error"}). Sessions, data changes
and events are kept here by name, so a test can subscribe, act, then read what
arrived. Hostile clients (a browse loop, many sessions, subscribing to every
variable at 10 ms) run as background tasks while the test measures the plant.

Requests: connect, disconnect, browse, read, subscribe, changes, subscribe_events,
events, call, condition_refresh, ack, shelve, cert, browse_loop, sessions,
subscribe_all, stop_hostile. See each handler.
"""
import asyncio
import json
import os
import sys
import time

from asyncua import Client, ua
from asyncua.common.events import Event
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256

STATUS = ua.status_codes


def status_name(code):
    value = code.value if hasattr(code, "value") else int(code)
    return STATUS.get_name_and_doc(value)[0]


def plain(value):
    """A value as JSON can carry it."""
    if isinstance(value, float) and value != value:
        return None  # NaN: an actuator never reported (JSON has no NaN)
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    if isinstance(value, (bytes, bytearray)):
        return value.hex()
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, ua.LocalizedText):
        return value.Text
    if isinstance(value, ua.NodeId):
        return value.to_string()
    if isinstance(value, ua.QualifiedName):
        return value.Name
    if isinstance(value, ua.StatusCode):
        return status_name(value)
    if hasattr(value, "isoformat"):
        return value.isoformat()
    if hasattr(value, "Low") and hasattr(value, "High"):
        return {"low": value.Low, "high": value.High}
    if hasattr(value, "DisplayName") and hasattr(value, "UnitId"):
        return {"unitId": value.UnitId, "displayName": plain(value.DisplayName)}
    return str(value)


class Recorder:
    """Receives a subscription's data changes and events (only counts them when `count_only`)."""

    def __init__(self, count_only=False):
        self.changes = []
        self.events = []
        self.count_only = count_only
        self.count = 0

    def datachange_notification(self, node, val, data):
        self.count += 1
        if self.count_only:
            return
        dv = data.monitored_item.Value
        self.changes.append({
            "nodeId": node.nodeid.to_string(), "value": plain(val),
            "status": status_name(dv.StatusCode) if dv is not None and dv.StatusCode is not None else "Good",
            "at": time.time(),
        })

    def event_notification(self, event: Event):
        fields = event.get_event_props_as_fields_dict()
        record = {name: plain(variant.Value) for name, variant in fields.items()}
        record["at"] = time.time()
        self.events.append(record)

    def status_change_notification(self, status):
        pass


class Bridge:
    def __init__(self):
        self.clients = {}
        self.recorders = {}
        self.subscriptions = {}
        self.hostile = []

    # ---- sessions -----------------------------------------------------------------

    async def connect(self, name, url, user=None, password=None, security=None, cert=None, key=None, timeout=10, count_only=False):
        # The watchdog's read of the server state waits as long as any request: on a loaded machine
        # a large plant's server answers late, which is not a lost connection.
        client = Client(url, timeout=timeout, watchdog_intervall=max(1.0, timeout / 4))
        client.application_uri = "urn:sugarshack:tests:asyncua"
        if security and security != "None":
            mode = ua.MessageSecurityMode.SignAndEncrypt if security == "SignAndEncrypt" else ua.MessageSecurityMode.Sign
            await client.set_security(SecurityPolicyBasic256Sha256, cert, key, mode=mode)
        if user is not None:
            client.set_user(user)
            client.set_password(password)
        await client.connect()
        self.clients[name] = client
        self.recorders[name] = Recorder(count_only)
        return {"endpoint": client.security_policy.URI if client.security_policy else "None"}

    async def disconnect(self, name):
        client = self.clients.pop(name, None)
        self.subscriptions.pop(name, None)
        if client:
            await client.disconnect()
        return {}

    def client(self, name):
        return self.clients[name]

    # ---- reading ------------------------------------------------------------------

    async def browse(self, name, root="ns=0;i=85", depth=6):
        """Every node under `root` (Objects by default) down to `depth`: path, node id, class, type."""
        client = self.client(name)
        found = []

        async def walk(node, path, level):
            if level > depth:
                return
            for ref in await node.get_references(refs=ua.ObjectIds.HierarchicalReferences, direction=ua.BrowseDirection.Forward):
                if ref.NodeId.NamespaceIndex == 0 and level > 0:
                    continue  # the standard's own nodes under ours (properties of types) are not listed
                child = client.get_node(ref.NodeId)
                child_path = f"{path}/{ref.BrowseName.Name}" if path else ref.BrowseName.Name
                found.append({"path": child_path, "nodeId": ref.NodeId.to_string(), "nodeClass": ref.NodeClass.name,
                              "type": ref.TypeDefinition.to_string()})
                if ref.NodeClass in (ua.NodeClass.Object, ua.NodeClass.Variable):
                    await walk(child, child_path, level + 1)

        await walk(client.get_node(root), "", 0)
        return found

    async def read(self, name, nodeIds):
        client = self.client(name)
        nodes = [client.get_node(n) for n in nodeIds]
        values = await client.read_attributes(nodes, ua.AttributeIds.Value)
        return [{"nodeId": n, "value": plain(dv.Value.Value if dv.Value is not None else None), "status": status_name(dv.StatusCode)}
                for n, dv in zip(nodeIds, values)]

    async def namespace(self, name, uri):
        return await self.client(name).get_namespace_index(uri)

    # ---- subscriptions ---------------------------------------------------------------

    async def subscription(self, name, interval):
        key = (name, interval)
        if key not in self.subscriptions.setdefault(name, {}):
            self.subscriptions[name][key] = await self.client(name).create_subscription(interval, self.recorders[name])
        return self.subscriptions[name][key]

    async def subscribe(self, name, nodeIds, interval=100, sampling=None):
        sub = await self.subscription(name, interval)
        client = self.client(name)
        nodes = [client.get_node(n) for n in nodeIds]
        await sub.subscribe_data_change(nodes, sampling_interval=interval if sampling is None else sampling)
        return {"count": len(nodes)}

    async def changes(self, name):
        return self.recorders[name].changes

    async def count(self, name):
        """How many data changes session `name` received."""
        return self.recorders[name].count

    async def subscribe_ids(self, name, ns, paths, interval=100, sampling=250, chunk=5000):
        """Subscribes to our nodes by path (`s=<path>` in namespace `ns`), in calls of `chunk` items."""
        for i in range(0, len(paths), chunk):
            await self.subscribe(name, [f"ns={ns};s={p}" for p in paths[i:i + chunk]], interval, sampling)
        return {"count": len(paths)}

    async def subscribe_events(self, name, interval=100):
        sub = await self.subscription(name, interval)
        client = self.client(name)
        alarm_type = client.get_node(ua.NodeId(ua.ObjectIds.AlarmConditionType))
        # A queue for a burst of events (a refresh, an e-stop of several lines): 0 would keep only the newest.
        await sub.subscribe_alarms_and_conditions(client.nodes.server, alarm_type, queuesize=1000)
        return {}

    async def events(self, name):
        return self.recorders[name].events

    async def condition_refresh(self, name):
        """ConditionType.ConditionRefresh for the session's (first) subscription: the retained conditions again."""
        sub = next(iter(self.subscriptions[name].values()))
        return await self.call(name, "i=2782", "i=3875", [{"type": "UInt32", "value": sub.subscription_id}])

    # ---- methods ------------------------------------------------------------------

    async def call(self, name, objectId, methodId, args):
        """A method call as the wire has it: the result's status and output arguments, even when Bad."""
        request = ua.CallMethodRequest()
        request.ObjectId = ua.NodeId.from_string(objectId)
        request.MethodId = ua.NodeId.from_string(methodId)
        request.InputArguments = [variant(a) for a in args]
        results = await self.client(name).uaclient.call([request])
        result = results[0]
        return {"status": status_name(result.StatusCode), "outputs": [plain(v.Value) for v in (result.OutputArguments or [])]}

    async def ack(self, name, conditionId, eventId, comment):
        return await self.call(name, conditionId, "i=9111", [
            {"type": "ByteString", "value": eventId}, {"type": "LocalizedText", "value": comment}])

    async def shelve(self, name, conditionId, how, ms=None):
        """Calls TimedShelve, OneShotShelve or Unshelve on the condition's ShelvingState."""
        client = self.client(name)
        shelving = await client.get_node(conditionId).get_child("0:ShelvingState")
        method = {"timed": "0:TimedShelve", "oneshot": "0:OneShotShelve", "unshelve": "0:Unshelve"}[how]
        method_node = await shelving.get_child(method)
        args = [{"type": "Double", "value": ms}] if how == "timed" else []
        return await self.call(name, shelving.nodeid.to_string(), method_node.nodeid.to_string(), args)

    # ---- certificates -------------------------------------------------------------------

    async def cert(self, dir):
        """A client certificate for Basic256Sha256 (PEM key and DER certificate in `dir`)."""
        from asyncua.crypto.cert_gen import generate_private_key, generate_self_signed_app_certificate, dump_private_key_as_pem
        from cryptography.hazmat.primitives import serialization
        from cryptography import x509
        from cryptography.x509.oid import ExtendedKeyUsageOID
        key = generate_private_key()
        names = {"organizationName": "sugarshack"}
        cert = generate_self_signed_app_certificate(
            key, "sugarshack tests", names, [x509.UniformResourceIdentifier("urn:sugarshack:tests:asyncua"), x509.DNSName("localhost")],
            extended=[ExtendedKeyUsageOID.CLIENT_AUTH], days=30)
        key_path = os.path.join(dir, "client-key.pem")
        cert_path = os.path.join(dir, "client-cert.der")
        with open(key_path, "wb") as f:
            f.write(dump_private_key_as_pem(key))
        with open(cert_path, "wb") as f:
            f.write(cert.public_bytes(serialization.Encoding.DER))
        return {"cert": cert_path, "key": key_path}

    # ---- hostile clients -------------------------------------------------------------

    async def browse_loop(self, name, seconds, parallel=4):
        """Browses the whole plant again and again for `seconds`, `parallel` crawls at once (in the background); answers at once."""
        async def loop():
            end = time.time() + seconds
            rounds = 0
            while time.time() < end:
                await self.browse(name, "ns=0;i=85", 4)
                rounds += 1
            return rounds

        async def run():
            counts = await asyncio.gather(*[loop() for _ in range(parallel)])
            return {"rounds": sum(counts)}
        task = asyncio.ensure_future(run())
        self.hostile.append(task)
        return {}

    async def sessions(self, url, count, hold_seconds):
        """Opens `count` anonymous sessions at once and holds the ones the server took (in the background)."""
        async def one():
            client = Client(url, timeout=15)
            try:
                await client.connect()
            except Exception as err:  # refused past the server's limit: what a hostile client gets
                return None, type(err).__name__
            return client, None

        async def run():
            opened = await asyncio.gather(*[one() for _ in range(count)])
            clients = [c for c, _ in opened if c]
            await asyncio.sleep(hold_seconds)
            for c in clients:
                try:
                    await c.disconnect()
                except Exception:
                    pass
            return {"opened": len(clients), "refused": count - len(clients)}
        task = asyncio.ensure_future(run())
        self.hostile.append(task)
        return {}

    async def subscribe_all(self, name, interval):
        """Subscribes to every variable of our namespace at `interval` ms (sampling and publishing)."""
        found = await self.browse(name, "ns=0;i=85", 6)
        ns = await self.client(name).get_namespace_index("https://github.com/sugarshack/sugarshack/UA/")
        variables = [n["nodeId"] for n in found if n["nodeClass"] == "Variable" and n["nodeId"].startswith(f"ns={ns};")]
        await self.subscribe(name, variables, interval, interval)
        return {"count": len(variables)}

    async def stop_hostile(self):
        results = []
        for task in self.hostile:
            try:
                results.append(await asyncio.wait_for(task, 60))
            except Exception as err:
                results.append({"error": repr(err)})
        self.hostile = []
        return results


def variant(arg):
    kind = arg["type"]
    value = arg["value"]
    if kind == "ByteString":
        return ua.Variant(bytes.fromhex(value), ua.VariantType.ByteString)
    if kind == "LocalizedText":
        return ua.Variant(ua.LocalizedText(value), ua.VariantType.LocalizedText)
    if kind == "StringArray":
        return ua.Variant(list(value), ua.VariantType.String)
    return ua.Variant(value, getattr(ua.VariantType, kind))


async def main():
    bridge = Bridge()
    loop = asyncio.get_event_loop()
    reader = asyncio.StreamReader(limit=64 * 1024 * 1024)  # a request may name every node of a large plant
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)

    async def handle(request):
        try:
            result = await getattr(bridge, request["op"])(**request.get("args", {}))
            answer = {"id": request["id"], "result": result}
        except Exception as err:
            answer = {"id": request["id"], "error": f"{type(err).__name__}: {err}",
                      "status": status_name(err.code) if hasattr(err, "code") else None}
        sys.stdout.write(json.dumps(answer) + "\n")
        sys.stdout.flush()

    sys.stdout.write(json.dumps({"ready": True}) + "\n")
    sys.stdout.flush()
    while True:
        line = await reader.readline()
        if not line:
            break
        asyncio.ensure_future(handle(json.loads(line)))


if __name__ == "__main__":
    asyncio.run(main())
