// Node ads-client (jisotalo, the version in package-lock.json) against a running liftd:
//   node session.mjs <mode> <liftd TCP port> <liftd NetId> [seconds]
// mode: default (router port connect + PLC-runtime setup, how Node-RED connects),
//       raw (rawClient with a local NetId/port: no router, no runtime probing),
//       bench (default mode, readValue of lift_active in a loop for [seconds]),
//       upload (default mode, getSymbols() + getDataTypes(), timed).
// Prints one JSON object; exits 1 with {"error": ...} on the first failure.
import { readFileSync } from 'node:fs';
import { Client } from 'ads-client';

const [mode, port, netId, seconds] = process.argv.slice(2);
const LIFT = 'GEO.ch1.Z.lift_active';
const SUPPRESSED = 'GEO.ch1.Z.lift_suppressed';
const OVERRIDE = 'PLC.ch1.override';
const pkg = new URL('./node_modules/ads-client/package.json', import.meta.url);
const out = { mode, version: JSON.parse(readFileSync(pkg, 'utf8')).version };

const base = { targetAmsNetId: netId, targetAdsPort: 551, routerAddress: '127.0.0.1', routerTcpPort: Number(port),
  hideConsoleWarnings: true, autoReconnect: false, timeoutDelay: 3000 };
const settings = mode === 'raw'
  // Setup 3 of the ads-client README: no router, our own AMS address, no PLC probing
  ? { ...base, rawClient: true, localAmsNetId: '127.0.0.3.1.1', localAdsPort: 32750 }
  : base;

const client = new Client(settings);

async function waitFor(cond, ms, poll = async () => {}) {
  const t0 = Date.now();
  for (;;) {
    await poll();
    if (cond()) return;
    if (Date.now() - t0 > ms) throw new Error('timeout');
    await new Promise((r) => setTimeout(r, 10));
  }
}

async function symbolMode() {
  out.lift_active = (await client.readValue(LIFT)).value;
  out.lift_suppressed = (await client.readValue(SUPPRESSED)).value;
  out.override_before = (await client.readValue(OVERRIDE)).value;
  await client.writeValue(OVERRIDE, 750); // takes effect in the next GEO cycle
  let after;
  await waitFor(() => after === 750, 3000, async () => { after = (await client.readValue(OVERRIDE)).value; });
  out.override_after = after;
  try {
    await client.writeValue(LIFT, true);
    out.write_read_only = 'accepted';
  } catch (err) {
    out.write_read_only = err.adsError ? err.adsError.errorCode : String(err.message);
  }
  const dt = await client.getDataType('BOOL');
  out.data_type = { name: dt.type, size: dt.size, adsDataType: dt.adsDataType };
  const sym = await client.getSymbol(LIFT);
  out.symbol = { type: sym.type, size: sym.size, indexGroup: sym.indexGroup, indexOffset: sym.indexOffset };
  const seen = { [LIFT]: [], [SUPPRESSED]: [], [OVERRIDE]: [] };
  const subs = [];
  for (const path of Object.keys(seen)) {
    subs.push(await client.subscribeValue(path, (data) => seen[path].push(data.value), 10, true));
  }
  await client.writeValue(OVERRIDE, 1000);
  await waitFor(() => Object.values(seen).every((v) => v.length > 0) && seen[OVERRIDE].includes(1000), 3000);
  out.subscribed = Object.fromEntries(Object.entries(seen).map(([k, v]) => [k, v.slice(0, 3)]));
  for (const s of subs) await s.unsubscribe();
  const symbols = await client.getSymbols();
  const types = await client.getDataTypes();
  out.symbol_count = Object.keys(symbols).length;
  out.data_type_count = Object.keys(types).length;
}

async function rawMode() {
  out.device = await client.readDeviceInfo();
  out.state = await client.readState();
  out.raw_lift = (await client.readRaw(0x121301, 0x30095, 1)).readUInt8(0);
  const handle = await client.createVariableHandle(LIFT);
  out.handle = { size: handle.size, dataType: handle.dataType };
  out.by_handle = (await client.readRawByHandle(handle)).readUInt8(0);
  await client.deleteVariableHandle(handle);
  const multi = await client.createVariableHandleMulti([LIFT, SUPPRESSED, 'GEO.nope']);
  out.handle_multi = multi.map((m) => (m.success ? m.handle.size : m.errorCode));
  await client.deleteVariableHandleMulti(multi.filter((m) => m.success).map((m) => m.handle));
  const sums = await client.readRawMulti([
    { indexGroup: 0x121301, indexOffset: 0x30095, size: 1 },
    { indexGroup: 0x121301, indexOffset: 0x30094, size: 1 },
    { indexGroup: 0x121301, indexOffset: 0x77, size: 1 },
  ]);
  out.sum_read = sums.map((r) => (r.success ? r.value.readUInt8(0) : r.errorCode));
  await client.writeRawByPath(OVERRIDE, Buffer.from([0xe8, 0x03])); // 1000 = 100 %
  out.raw_by_path = (await client.readRawByPath(OVERRIDE)).readUInt16LE(0);
  const seen = [];
  const sub = await client.subscribeRaw(0x121301, 0x30095, 1, (data) => seen.push(data.value.readUInt8(0)), 10);
  await waitFor(() => seen.length > 0, 3000);
  await sub.unsubscribe();
  out.subscribe_raw = seen.length > 0;
  // an address of unknown size: ads-client subscribes with length 0xFFFFFFFF
  const sizes = [];
  const any = await client.subscribe({
    target: { indexGroup: 0x121301, indexOffset: 0x30095 },
    callback: (data) => sizes.push(data.value.length),
    cycleTime: 10,
  });
  await waitFor(() => sizes.length > 0, 3000);
  await any.unsubscribe();
  out.subscribe_unknown_size = sizes;
}

async function bench() {
  const end = Date.now() + 1000 * Number(seconds || 3);
  let n = 0;
  const t0 = process.hrtime.bigint();
  while (Date.now() < end) {
    await client.readValue(LIFT);
    n += 1;
  }
  const s = Number(process.hrtime.bigint() - t0) / 1e9;
  out.read_value_per_s = n / s;
  out.reads = n;
}

async function upload() {
  const t0 = process.hrtime.bigint();
  const symbols = await client.getSymbols();
  const types = await client.getDataTypes();
  out.upload_ms = Number(process.hrtime.bigint() - t0) / 1e6;
  out.symbol_count = Object.keys(symbols).length;
  out.data_type_count = Object.keys(types).length;
}

try {
  const conn = await client.connect();
  out.connection = { localAmsNetId: conn.localAmsNetId, localAdsPort: conn.localAdsPort };
  if (mode === 'raw') await rawMode();
  else if (mode === 'bench') await bench();
  else if (mode === 'upload') await upload();
  else await symbolMode();
  await client.disconnect();
  console.log(JSON.stringify(out));
} catch (err) {
  out.error = `${err.message}${err.adsError ? ` (ADS ${err.adsError.errorCode})` : ''}`;
  console.log(JSON.stringify(out));
  try { await client.disconnect(true); } catch { /* already gone */ }
  process.exit(1);
}
