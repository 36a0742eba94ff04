// The monitor page (/monitor, docs/phone.md) end to end: headless Chromium against the
// real phone bridge (given the floor map), sensor, compute and feedback agents on a
// loopback Zenoh bus, with schemas/python/monitor.py reading the same bus, so what the
// page draws is checked against what the bus carried.
//
//     node --test tests/browser/monitor.test.mjs      # from the repository root
//
// Environment as for phone.test.mjs (see harness.mjs). Logs go to
// target/browser-artifacts/monitor-*, the page's screenshot to target/monitor.png.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after } from 'node:test';

import { artifacts, binDir, freePort, harness, here, python, root } from './harness.mjs';

const USER = 'monitor-e2e';
const BUDGET_MS = 60000; // the whole test, start to end (it takes about 10 s)
const DESTINATION = 'room 204';
const SAID = 'Monitor test: door on your left.';
const AGENTS = ['compute-agent', 'feedback-agent', 'phone-bridge', 'sensor-agent'];

const bus = [];        // {at, line}: one object per line of monitor.py --json
const framesOut = [];  // what the page sent the bridge
const pageErrors = [];
let page = null;
let bridge = null;
let endpoint = null;
let stateDir = null;

const h = harness({ budgetMs: BUDGET_MS, seen: () => seen(), prefix: 'monitor' });
const { start, waitFor, step } = h;

const onBus = (suffix) => bus.filter((m) => m.line.key === `wearnav/${USER}/${suffix}`).map((m) => m.line);

async function seen() {
  // the utterances first, each on one line: a CI log keeps only the start of this
  const spoken = onBus('feedback/speech').reverse()
    .map((m) => `${new Date(m.header.capture_ns / 1e6).toISOString()} ${m.header.sender}#${m.header.seq} ${m.body.text}`);
  let said = '(no page)';
  let dom = '(no page)';
  if (page) {
    said = await page.evaluate(() => [...document.querySelectorAll('#utterances li')]
      .map((li) => `${li.querySelector('time').dateTime} ${li.lastChild.textContent}`))
      .then((l) => JSON.stringify(l.slice(0, 8)), (e) => `page unavailable: ${e.message}`);
    dom = await page.evaluate(() => ({
      connection: document.getElementById('connection').textContent,
      alert: document.getElementById('alert').textContent,
      scan: { ...document.getElementById('scan').dataset },
      map: { ...document.getElementById('map').dataset },
      rumble: window.__rumble || null,
      agents: [...document.querySelectorAll('#agents-table tbody tr')].map((tr) => `${tr.dataset.agent}:${tr.dataset.alive}`),
    })).then((s) => JSON.stringify(s), (e) => `page unavailable: ${e.message}`);
  }
  const keys = {};
  for (const m of bus) keys[m.line.key] = (keys[m.line.key] || 0) + 1;
  return [`said on the page, newest first: ${said}`, `said on the bus, newest first: ${JSON.stringify(spoken.slice(0, 8))}`,
    `page: ${dom}`, `bus messages by key: ${JSON.stringify(keys)}`,
    `page errors: ${JSON.stringify(pageErrors.slice(-5))}`, h.exits()].join('\n');
}

/** Run send.py (it waits for a subscriber, so the one put is not lost). */
function send(args) {
  const child = start(`send-${args[0]}`, python, ['schemas/python/send.py', '--user', USER, '--connect', endpoint, ...args]);
  return waitFor(`send.py ${args.join(' ')} to finish`, () => {
    if (child.spawnError) assert.fail(h.describeExit(child));
    if (child.exited) return child.exited.code === 0 ? true : assert.fail(h.describeExit(child));
    return false;
  }, 10000);
}

after(async () => {
  await h.finish();
  if (stateDir) fs.rmSync(stateDir, { recursive: true, force: true });
});

step('agents', [], 'the bridge (with the floor map) and the agents start on a loopback bus', 40000, async () => {
  h.requireBinaries(['phone-bridge', 'sensor-agent', 'compute-agent', 'feedback-agent']);
  const port = await freePort();
  endpoint = `tcp/127.0.0.1:${port}`;
  stateDir = fs.mkdtempSync(path.join(os.tmpdir(), 'wearnav-monitor-e2e-'));
  const peer = ['--user', USER, '--connect', endpoint, '--no-multicast'];
  bridge = await h.startBridge('phone-bridge', ['--user', USER, '--listen', endpoint, '--no-multicast',
    '--state-dir', stateDir, '--map', 'maps/building'], '127.0.0.1:0');
  start('bus', python, ['schemas/python/monitor.py', '--user', USER, '--connect', endpoint, '--json'], (line) => {
    try { bus.push({ at: Date.now(), line: JSON.parse(line) }); } catch (e) { /* not JSON: kept in the file */ }
  });
  start('sensor-agent', path.join(binDir, 'sensor-agent'), [...peer, '--source', 'sim:building']);
  start('compute-agent', path.join(binDir, 'compute-agent'), [...peer, '--map', 'maps/building', '--start', '1,5,0,0']);
  start('feedback-agent', path.join(binDir, 'feedback-agent'), peer);
});

step('page', ['agents'], 'the monitor page pairs and subscribes on the phone\'s socket', 20000, async () => {
  ({ page } = await h.launchChromium({ viewport: { width: 1400, height: 1000 } }));
  page.on('pageerror', (e) => pageErrors.push(e.message));
  page.on('websocket', (ws) => ws.on('framesent', (f) => {
    try { framesOut.push(JSON.parse(f.payload)); } catch (e) { /* not ours */ }
  }));
  await page.goto(`${bridge.url}monitor`);
  const code = page.getByLabel('Pairing code');
  await waitFor('the pairing form of the monitor page', () => code.isVisible(), 5000);
  await code.fill(bridge.code);
  await page.getByRole('button', { name: 'Pair', exact: true }).click();
  await waitFor('the page to say it watches the user', async () =>
    (await page.locator('#connection').textContent()) === `Connection: watching ${USER}.`, 10000);
  const asked = framesOut.find((m) => m.type === 'subscribe');
  assert.deepEqual(asked && [...asked.streams].sort(),
    ['haptic', 'hazard', 'health', 'map', 'pose', 'route', 'scan', 'speech', 'truth']);
  // every change of each side's rumble, as the page shows it
  await page.evaluate(() => {
    window.__rumble = { left: [], right: [] };
    for (const side of ['left', 'right']) {
      const el = document.getElementById(`rumble-${side}`);
      new MutationObserver(() => {
        const log = window.__rumble[side];
        const state = el.dataset.state;
        if (log[log.length - 1]?.state !== state) log.push({ state, text: el.querySelector('strong').textContent, t: Date.now() });
      }).observe(el, { attributes: true, attributeFilter: ['data-state'] });
    }
  });
});

step('scan', ['page'], 'the scan drawn has the beams and the nearest range of a scan on the bus', 15000, async () => {
  const drawn = await waitFor('a scan drawn (data-seq on #scan)', () =>
    page.evaluate(() => { const d = document.getElementById('scan').dataset; return d.seq ? { ...d } : null; }), 10000);
  const onTheBus = await waitFor(`scan #${drawn.seq} from the compute agent on the bus`, () =>
    onBus('perception/scan').find((m) => m.header.seq === Number(drawn.seq) && m.header.sender === 'compute-agent'), 3000);
  const ranges = onTheBus.body.ranges_m;
  const seenRanges = ranges.filter((r) => r !== null);
  assert.equal(Number(drawn.beams), ranges.length, 'beams drawn = beams of the scan on the bus');
  assert.equal(Number(drawn.points), seenRanges.length, 'points drawn = beams that saw an obstacle');
  assert.ok(seenRanges.length > 0, 'the building is not empty ahead of the user');
  const nearest = Math.min(...seenRanges);
  assert.ok(Math.abs(Number(drawn.nearestM) - nearest) <= 0.0006,
    `nearest drawn ${drawn.nearestM} m, on the bus ${nearest} m (shown to the millimetre)`);
  const caption = await page.locator('#scan-facts').textContent();
  assert.match(caption, new RegExp(`^${drawn.beams} beams of 1\\.0° from -30°`), caption);
});

step('rumble', ['page'], 'each side\'s rumble shows on and off as the haptic intents on the bus change', 20000, async () => {
  const log = await waitFor('both sides seen on, then off again', async () => {
    const r = await page.evaluate(() => window.__rumble);
    const cycled = (side) => side.findIndex((e) => e.state === 'on') >= 0 && side.slice(side.findIndex((e) => e.state === 'on')).some((e) => e.state === 'off');
    return cycled(r.left) && cycled(r.right) && r;
  }, 15000);
  for (const side of ['left', 'right']) {
    const on = log[side].find((e) => e.state === 'on');
    assert.match(on.text, /^on \d+ %$/, `${side} on says its level: ${on.text}`);
    assert.ok(onBus('feedback/haptic').some((m) => m.body[side] > 0 && m.header.capture_ns / 1e6 <= on.t),
      `a haptic intent with ${side} > 0 on the bus before the page showed ${side} on`);
  }
  assert.deepEqual(await page.getByRole('status', { name: 'Left rumble' }).count(), 1, 'the left side is a named status');
});

step('speech', ['page'], 'the utterances fill the list, the newest first', 20000, async () => {
  await send(['cmd', 'destination', DESTINATION]);
  await waitFor(`an utterance "Route to ${DESTINATION}: ..." in the list`, () =>
    page.evaluate((d) => [...document.querySelectorAll('#utterances li')].some((li) => li.textContent.includes(`Route to ${d}:`)), DESTINATION), 10000);
  await send(['speech', SAID, '--priority', 'important']);
  // (it cuts the route's start off if that is still being said; the guide then says
  // the start again, which lands above it)
  const said = await waitFor(`"${SAID}" in the list`, () =>
    page.evaluate((t) => { const li = [...document.querySelectorAll('#utterances li')].find((l) => l.textContent.endsWith(t)); return li && li.textContent; }, SAID), 5000);
  assert.match(said, /^\d\d:\d\d:\d\dimportant/, `time and priority before the words: ${said}`);
  // the list is the bus's utterances, newest first; before the page connected (and
  // before monitor.py did) the bridge said its pairing code: the page got it from the
  // bridge's state. Each utterance is known by its capture time (the list's datetime,
  // to the millisecond) and words. Two publishers' utterances a few milliseconds apart
  // (the start said again after the words above cut it) may reach the bridge and
  // monitor.py in either order, so the newest on the page are the bus's, each sender's
  // in the bus's order.
  // (read until both sides agree: a start said again may reach one before the other)
  const listed = await waitFor('the list to be what feedback/speech carried, newest first', async () => {
    const list = await page.evaluate(() => [...document.querySelectorAll('#utterances li')]
      .map((li) => `${li.querySelector('time').dateTime} ${li.lastChild.textContent}`));
    const spoken = onBus('feedback/speech').reverse()
      .map((m) => ({ sender: m.header.sender, id: `${new Date(m.header.capture_ns / 1e6).toISOString()} ${m.body.text}` }));
    if (spoken.length === 0) return false;
    const newest = list.slice(0, spoken.length);
    if (JSON.stringify([...newest].sort()) !== JSON.stringify(spoken.map((s) => s.id).sort())) return false;
    const senders = new Set(spoken.map((s) => s.sender));
    const inOrder = [...senders].every((sender) => {
      const theirs = spoken.filter((s) => s.sender === sender).map((s) => s.id);
      return JSON.stringify(newest.filter((id) => theirs.includes(id))) === JSON.stringify(theirs);
    });
    return inOrder && list;
  }, 3000);
  assert.match(listed[listed.length - 1], /^\S+Z Phone bridge ready\. Pairing code( \d){6}\.$/, 'the oldest, said before the page came');
});

step('map', ['speech'], 'the floor map shows the pose, and the route to the destination', 15000, async () => {
  const drawn = await waitFor('the map drawn with a pose on floor 0', () =>
    page.evaluate(() => { const d = document.getElementById('map').dataset; return d.map === 'drawn' && d.pose ? { ...d } : null; }), 5000);
  assert.equal(drawn.floor, '0');
  const [x, y] = drawn.pose.split(',').map(Number);
  assert.ok(onBus('localization/pose').some((m) => Math.abs(m.body.x_m - x) < 0.006 && Math.abs(m.body.y_m - y) < 0.006),
    `the pose drawn (${x}, ${y}) is one the localization published`);
  await waitFor(`the route facts to name ${DESTINATION}`, async () =>
    /^Route (guiding|waiting-for-position) to room 204/.test(await page.locator('#route-facts').textContent()), 5000);
  assert.match(await page.locator('#pose-facts').textContent(), /^Pose (tracking|converging|converging \(followed: guidance takes it\)): \(.+\) m, heading .+, 95 % within/);
  assert.match(await page.locator('#map-note').textContent(), /publishes its covariance, not its particles/);
});

step('scan-on-map', ['map'], 'the latest scan is drawn on the map where the camera place of its frame puts it', 10000, async () => {
  const drawn = await waitFor('a scan drawn on the map (data-scan-seq on #map)', () =>
    page.evaluate(() => { const d = document.getElementById('map').dataset; return d.scanSeq ? { ...d } : null; }), 5000);
  const scan = await waitFor(`scan #${drawn.scanSeq} from the compute agent on the bus`, () =>
    onBus('perception/scan').find((m) => m.header.seq === Number(drawn.scanSeq) && m.header.sender === 'compute-agent'), 3000);
  const place = await waitFor('the camera place of the same frame on the bus', () =>
    onBus('localization/camera').find((m) => m.header.capture_ns === scan.header.capture_ns), 3000);
  const { angle_min_deg: first, angle_increment_deg: step, ranges_m: ranges } = scan.body;
  const { x_m: cx, y_m: cy, yaw_rad: yaw } = place.body;
  const expected = [];
  ranges.forEach((r, i) => {
    if (r === null) return;
    const a = yaw + (first + i * step) * Math.PI / 180;
    expected.push([cx + r * Math.cos(a), cy + r * Math.sin(a)]);
  });
  const points = drawn.scanPoints.split(' ').map((p) => p.split(',').map(Number));
  assert.ok(expected.length > 0, 'the building is not empty ahead of the user');
  assert.equal(points.length, expected.length, 'a point on the map for each beam that saw something');
  // the page has the ranges to the millimetre and writes the points to the millimetre
  const off = Math.max(...points.map((p, i) => Math.hypot(p[0] - expected[i][0], p[1] - expected[i][1])));
  assert.ok(off < 0.002, `the points drawn are where the bus's scan and camera place put them (${off} m off at most)`);
});

step('health', ['page'], 'every agent is listed alive and ok, with the latency of what it reads', 10000, async () => {
  const rows = await waitFor(`rows for ${AGENTS.join(', ')}, alive and ok`, () => page.evaluate((names) => {
    const rows = [...document.querySelectorAll('#agents-table tbody tr')].map((tr) => ({
      agent: tr.dataset.agent, alive: tr.dataset.alive, cells: [...tr.children].map((c) => c.textContent),
    }));
    return names.every((n) => rows.some((r) => r.agent === n && r.alive === 'true' && r.cells[2] === 'ok')) && rows;
  }, AGENTS), 8000);
  const compute = rows.find((r) => r.agent === 'compute-agent');
  assert.match(compute.cells[5], /sensor\/\*\/depth \d+\.\d\/s \d+\.\d\/\d+\.\d ms/, `compute-agent's depth rate and age: ${compute.cells[5]}`);
});

step('look', ['scan', 'rumble', 'speech', 'map', 'scan-on-map', 'health'], 'no serious accessibility violations; a screenshot', 10000, async () => {
  await page.addScriptTag({ path: path.join(here, 'node_modules/axe-core/axe.min.js') });
  const result = await page.evaluate(() => window.axe.run());
  const bad = result.violations.filter((v) => v.impact === 'serious' || v.impact === 'critical');
  assert.deepEqual(bad.map((v) => ({ id: v.id, help: v.help, nodes: v.nodes.map((n) => n.target.join(' ')) })), [],
    'axe-core: no serious or critical violations');
  // the canvases' words follow what they draw within 2 s (a screen reader's pace)
  const label = await waitFor('the scan canvas to be labelled with the scan drawn', async () => {
    const l = await page.locator('#scan-canvas').getAttribute('aria-label');
    return /^Scan: \d+ beams/.test(l) && l;
  }, 3000);
  assert.match(label, /^Scan: \d+ beams of 1\.0° from -30°, \d+ with an obstacle; (nearest \d+\.\d\d m|nothing within)/);
  await page.screenshot({ path: path.join(root, 'target/monitor.png'), fullPage: true });
  assert.deepEqual(pageErrors, [], 'no script errors in the page');
  assert.ok(fs.existsSync(artifacts));
});
