// An OSCQuery client that pointat did not write: node-oscquery (jangxx) finds a running patch by mDNS,
// reads its address space, sets one value over OSC and reads it back.
//
//   node client.mjs [--host 127.0.0.1] [--port P] --path /pointat/tqt/fuse/k_heading --set 0.2 [--timeout 10]
//
// Prints one JSON object on stdout; exits 1 when the value read back is not the one set, 2 on an error.
// With --port, only the service on that port counts, and a direct query of host:port is the fallback
// when mDNS finds nothing within --timeout seconds (the output says which: discovered_by).
import dgram from "node:dgram";
import { createRequire } from "node:module";
import { parseArgs } from "node:util";
import oscquery from "oscquery";

const { OSCQueryDiscovery, OSCQAccess, OSCTypeSimple } = oscquery;
const ACCESS = {
  [OSCQAccess.NO_VALUE]: "none",
  [OSCQAccess.READONLY]: "read-only",
  [OSCQAccess.WRITEONLY]: "write-only",
  [OSCQAccess.READWRITE]: "read-write",
};
// bonjour-service as node-oscquery itself loads it (its dependency, pinned by the lockfile).
const Bonjour = createRequire(createRequire(import.meta.url).resolve("oscquery"))("bonjour-service").default;

const { values: opt } = parseArgs({
  options: {
    host: { type: "string", default: "127.0.0.1" },
    port: { type: "string" },
    path: { type: "string", default: "/pointat/tqt/fuse/k_heading" },
    set: { type: "string", default: "0.2" },
    timeout: { type: "string", default: "10" },
  },
});
const wantedPort = opt.port === undefined ? undefined : Number(opt.port);
const timeoutMs = Number(opt.timeout) * 1000;
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));
// A watchdog: whatever hangs (an HTTP request, a socket), the script ends.
setTimeout(() => fail(`no answer within ${2 * timeoutMs + 5000} ms`), 2 * timeoutMs + 5000).unref();

// The library's OSCQueryDiscovery, with mDNS on the loopback interface only.  Its own start() builds
// `new Bonjour()` with no options: multicast-dns then joins 224.0.0.251 on every interface and sends its
// queries out of the default route's interface (eth0 on a networked machine), off the loopback, where
// pointat (advertising on 127.0.0.1 when it listens there) does not answer and a test must not send.
// And its _handleUp() drops a failed query's error (`this.emit(err)`: an event named by the error), so
// that is done here as there, with the error reported.  The rest (browsing _oscjson._tcp,
// queryNewService, the HTTP queries, parsing the tree) is the library's own.
class LoopbackDiscovery extends OSCQueryDiscovery {
  start() {
    this._mdns = new Bonjour({ interface: "127.0.0.1", bind: "0.0.0.0" }, (err) => this.emit("error", err));
    this._mdnsBrowser = this._mdns.find({ type: "oscjson", protocol: "tcp" });
    this._mdnsBrowser.on("up", (service) => {
      const { name, host, port, addresses = [] } = service;
      report.mdns.announced.push({ name, host, port, addresses });
      for (const address of addresses) {
        this.queryNewService(address, port).catch((err) => this.emit("query-error", { address, port, err }));
      }
    });
    this._mdnsBrowser.on("down", this._handleDown.bind(this));
  }
}

const report = { mdns: { announced: [] } }; // what is known so far, printed even on a failure

function fail(message) {
  process.stdout.write(JSON.stringify({ ...report, ok: false, error: message }) + "\n");
  process.exit(2);
}

// Find the service: by mDNS first, directly at host:port only if mDNS finds nothing in time.
async function discover() {
  const discovery = new LoopbackDiscovery();
  const matches = (s) => wantedPort === undefined || (s.port === wantedPort && s.address === opt.host);
  const found = new Promise((resolve, reject) => {
    discovery.on("up", (s) => matches(s) && resolve(s));
    discovery.on("query-error", (e) => {
      if (matches(e))
        reject(new Error(`found by mDNS at ${e.address}:${e.port}, but: ${e.err?.stack ?? e.err}`));
    });
    setTimeout(() => resolve(null), timeoutMs).unref();
  });
  discovery.on("error", (err) => process.stderr.write(`mDNS: ${err}\n`));
  discovery.start();
  try {
    const service = await found;
    if (service) return { service, discovered_by: "mdns" };
  } finally {
    discovery.stop();
  }
  if (wantedPort === undefined) fail(`mDNS found no _oscjson._tcp service within ${opt.timeout} s`);
  process.stderr.write(
    `mDNS found no service on port ${wantedPort}: querying ${opt.host}:${wantedPort} directly\n`,
  );
  return { service: await discovery.queryNewService(opt.host, wantedPort), discovered_by: "direct" };
}

// A method as the library parsed it.
function describe(service, path) {
  const method = service.flat().find((m) => m.full_path === path);
  if (!method) return null;
  const args = method.arguments ?? [];
  const typeName = Object.fromEntries(Object.entries(OSCTypeSimple).map(([k, v]) => [v, k]));
  return {
    type: args.map((a) => a.type).join(""),
    type_names: args.map((a) => typeName[a.type]),
    value: args.map((_, i) => service.resolvePath(path).getValue(i)),
    range: args.map((a) => a.range ?? null),
    access: ACCESS[method.access],
    description: method.description,
  };
}

// One OSC message with float arguments, encoded by hand (OSC 1.0: padded strings, big-endian float32).
function oscMessage(address, floats) {
  const padded = (s) => {
    const b = Buffer.from(s, "ascii");
    return Buffer.concat([b, Buffer.alloc(4 - (b.length % 4))]);
  };
  const args = Buffer.alloc(4 * floats.length);
  floats.forEach((f, i) => args.writeFloatBE(f, 4 * i));
  return Buffer.concat([padded(address), padded("," + "f".repeat(floats.length)), args]);
}

function send(host, port, message) {
  const socket = dgram.createSocket("udp4");
  return new Promise((resolve, reject) =>
    socket.send(message, port, host, (err) => (socket.close(), err ? reject(err) : resolve())),
  );
}

async function main() {
  const { service, discovered_by } = await discover();
  const methods = service.flat().filter((m) => m.arguments);
  const before = describe(service, opt.path);
  if (!before) fail(`${opt.path} is not in the address space (${methods.length} methods)`);

  const target = Number(opt.set);
  const f32 = Math.fround(target);
  const { oscIp, oscPort } = service.hostInfo;
  await send(oscIp || opt.host, oscPort, oscMessage(opt.path, [target]));
  let after;
  for (let i = 0; i < 20; i++) {
    // the set is carried out on the patch's scheduler: read until it shows, 2 s at most
    await service.update();
    after = describe(service, opt.path);
    if (Math.abs(after?.value?.[0] - f32) < 1e-6) break;
    await sleep(100);
  }
  const result = {
    discovered_by,
    ...report,
    service: { address: service.address, port: service.port },
    host_info: service.hostInfo,
    n_methods: methods.length,
    methods: Object.fromEntries(
      methods.map((m) => [
        m.full_path,
        { type: m.arguments.map((a) => a.type).join(""), access: ACCESS[m.access] },
      ]),
    ),
    path: opt.path,
    set: target,
    sent_to: { host: oscIp || opt.host, port: oscPort },
    before,
    after,
    ok: Math.abs(after?.value?.[0] - f32) < 1e-6,
  };
  process.stdout.write(JSON.stringify(result) + "\n");
  process.exit(result.ok ? 0 : 1);
}

main().catch((err) => fail(String(err?.stack ?? err)));
