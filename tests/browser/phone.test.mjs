// The phone page end to end: headless Chromium against the real phone bridge, sensor,
// compute and feedback agents on a loopback Zenoh bus (docs/phone.md).
//
//     node --test tests/browser/phone.test.mjs      # from the repository root
//
// WEARNAV_BIN_DIR (default target/debug) holds the agents' binaries; WEARNAV_PYTHON
// (default python3) is a Python with eclipse-zenoh, for schemas/python/monitor.py;
// WEARNAV_CHROMIUM (default /usr/bin/chromium) is the browser. Only the browser is
// instrumented: navigator.vibrate records its patterns, and speechSynthesis (silent in
// headless Chromium) records what it is asked to say and plays it at 40 ms a character.
// Every process's stdout and stderr (monitor.stdout: the bus, one JSON object a line),
// the page's WebSocket frames (frames.json) and a screenshot go to
// target/browser-artifacts/. The processes, the browser and the waits are harness.mjs's.

import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { after } from 'node:test';
import { isDeepStrictEqual } from 'node:util';

import { artifacts, binDir, freePort, harness, here, python } from './harness.mjs';

const USER = 'phone-e2e';
const BUDGET_MS = 170000; // the whole test, start to end
const DESTINATION = 'room 204';
// A place on the map the user says they are near: beside door 101, on the simulated
// user's floor (0), so the localization taking it does not move them elsewhere.
const PLACE = 'room 101';
// What guidance says first after Start: the route, or that the user is off it.
const isGuidance = (text) => text.startsWith(`Route to ${DESTINATION}:`) || text.startsWith('Off the route:');

const framesIn = [];   // {at, msg}: what the bridge sent the page
const framesOut = [];  // {at, msg}: what the page sent the bridge
const monitor = [];    // {at, line}: one object per line of monitor.py --json
const pageErrors = [];
let page = null;
let bridge = null;     // {child, url, code, httpPort}
let bridgeArgs = null;
let stateDir = null;
const { children, start, describeExit, exits, stop, waitFor, step, requireBinaries, launchChromium, startBridge: launchBridge, finish } =
  harness({ budgetMs: BUDGET_MS, seen: () => seen() });

// ---- Instrumentation, run in the page before its own script.
function instrument() {
  const calls = { vibrate: [], speak: [] };
  window.__wearnav = calls;
  Object.defineProperty(navigator, 'vibrate', {
    configurable: true,
    writable: true,
    value: (pattern) => {
      calls.vibrate.push({ pattern: JSON.parse(JSON.stringify(pattern)), t: Date.now() });
      return true;
    },
  });
  const synth = window.speechSynthesis;
  if (!synth) return;
  const queue = [];
  let current = null;
  let endTimer = null;
  const fire = (u, type, error) => {
    let e;
    try {
      e = error
        ? new SpeechSynthesisErrorEvent('error', { utterance: u, error })
        : new SpeechSynthesisEvent(type, { utterance: u });
    } catch (err) {
      e = new Event(type);
      if (error) e.error = error;
    }
    u.dispatchEvent(e);
  };
  const next = () => {
    if (current || !queue.length) return;
    const u = (current = queue.shift());
    fire(u, 'start');
    endTimer = setTimeout(() => {
      if (current !== u) return;
      current = null;
      fire(u, 'end');
      next();
    }, 40 * u.text.length);
  };
  synth.speak = (u) => {
    calls.speak.push({ text: u.text, t: Date.now() });
    queue.push(u);
    next();
  };
  synth.cancel = () => {
    clearTimeout(endTimer);
    const u = current;
    current = null;
    const dropped = queue.splice(0);
    if (u) fire(u, 'error', 'interrupted');
    for (const d of dropped) fire(d, 'error', 'canceled');
  };
}

// ---- Helpers.
async function pageState() {
  if (!page) return {};
  try {
    return await page.evaluate(() => ({
      connection: document.getElementById('connection').textContent,
      status: document.getElementById('status').textContent.replace(/\s+/g, ' ').trim(),
      alert: document.getElementById('alert').textContent,
      speak: (window.__wearnav?.speak || []).slice(-10),
      vibrate: (window.__wearnav?.vibrate || []).slice(-5),
    }));
  } catch (e) {
    return { unavailable: e.message };
  }
}

const brief = (frames, n) => frames.slice(-n).map((f) => JSON.stringify(f.msg)).join('\n  ');

/** What the page and the bus looked like, for a failure message. */
async function seen() {
  const s = await pageState();
  const notClock = (f) => f.msg.type !== 'clock';
  const speak = (s.speak || []).map((c) => JSON.stringify(c.text)).join('\n    ');
  const vibrate = (s.vibrate || []).map((c) => JSON.stringify(c.pattern)).join(' ');
  return [
    s.unavailable ? `page unavailable: ${s.unavailable}` : `page: connection "${s.connection}"; status "${s.status}"; alert "${s.alert}"`,
    `  last speak calls:\n    ${speak}`,
    `  last vibrate calls: ${vibrate}`,
    `last frames from the bridge:\n  ${brief(framesIn.filter(notClock), 12)}`,
    `last frames from the page:\n  ${brief(framesOut.filter(notClock), 12)}`,
    `page errors: ${JSON.stringify(pageErrors.slice(-5))}`,
    exits(),
  ].join('\n');
}

const calls = () => page.evaluate(() => window.__wearnav);
const text = (id) => page.locator(`#${id}`).textContent();
const appliedFromPhone = () => monitor
  .filter((m) => m.line.key === `wearnav/${USER}/feedback/applied` && m.line.body?.device === 'phone')
  .map((m) => m.line.body);
const acks = (event) => framesOut.filter((f) => f.msg.type === 'ack' && f.msg.event === event).map((f) => f.msg);

function startBridge(httpAddress) {
  return launchBridge(bridge ? 'phone-bridge-restarted' : 'phone-bridge', bridgeArgs, httpAddress);
}

after(async () => {
  await finish();
  const dump = { framesIn, framesOut, pageErrors };
  try { fs.writeFileSync(path.join(artifacts, 'frames.json'), JSON.stringify(dump, null, 1)); } catch (e) { /* best effort */ }
  if (stateDir) fs.rmSync(stateDir, { recursive: true, force: true });
});

// ---- The steps.

step('agents', [], 'the bridge and the agents start on a loopback bus', 40000, async () => {
  requireBinaries(['phone-bridge', 'sensor-agent', 'compute-agent', 'feedback-agent']);
  const port = await freePort();
  stateDir = fs.mkdtempSync(path.join(os.tmpdir(), 'wearnav-phone-e2e-'));
  const bus = ['--user', USER, '--connect', `tcp/127.0.0.1:${port}`, '--no-multicast'];
  bridgeArgs = ['--user', USER, '--listen', `tcp/127.0.0.1:${port}`, '--no-multicast', '--state-dir', stateDir];
  bridge = await startBridge('127.0.0.1:0');
  start('sensor-agent', path.join(binDir, 'sensor-agent'), [...bus, '--source', 'sim:building']);
  start('compute-agent', path.join(binDir, 'compute-agent'), [...bus, '--map', 'maps/building', '--start', '1,5,0,0']);
  start('feedback-agent', path.join(binDir, 'feedback-agent'), [...bus, '--haptic', 'phone', '--speech', 'phone']);
  start('monitor', python, ['schemas/python/monitor.py', '--user', USER, '--connect', `tcp/127.0.0.1:${port}`, '--json'], (line) => {
    try { monitor.push({ at: Date.now(), line: JSON.parse(line) }); } catch (e) { /* not JSON: kept in the file */ }
  });
});

step('pairing', ['agents'], 'the page pairs: a wrong code is refused and said, the right one connects', 30000, async () => {
  const browser = await launchChromium();
  await browser.context.addInitScript(instrument);
  page = browser.page;
  page.on('pageerror', (e) => pageErrors.push(e.message));
  page.on('websocket', (ws) => {
    const record = (into) => (f) => {
      try { into.push({ at: Date.now(), msg: JSON.parse(f.payload) }); } catch (e) { into.push({ at: Date.now(), msg: { unparsed: String(f.payload) } }); }
    };
    ws.on('framereceived', record(framesIn));
    ws.on('framesent', record(framesOut));
  });
  await page.goto(bridge.url);

  const codeBox = page.getByLabel('Pairing code');
  await waitFor('the pairing form (a "Pairing code" box and a "Pair" button)', async () =>
    (await codeBox.isVisible()) && (await page.getByRole('button', { name: 'Pair', exact: true }).isVisible()), 5000);
  const wrong = bridge.code === '000000' ? '999999' : '000000';
  await codeBox.fill(wrong);
  await page.getByRole('button', { name: 'Pair', exact: true }).click();
  await waitFor(`the alert region to say the code ${wrong} was wrong`, async () => /wrong/i.test(await text('alert')), 5000);
  const refusal = await text('alert');
  await waitFor(`the refusal "${refusal}" spoken`, async () => (await calls()).speak.some((s) => s.text === refusal), 5000);

  await codeBox.fill(bridge.code);
  await page.getByRole('button', { name: 'Pair', exact: true }).click();
  await waitFor('a hello from the bridge on the WebSocket', () => framesIn.some((f) => f.msg.type === 'hello'), 10000);
  await waitFor('the page to show it is connected', async () => /connected/i.test(await text('connection')), 5000);
  assert.equal(await codeBox.isVisible(), false, 'the pairing form is hidden once paired');
  const token = await page.evaluate(() => localStorage.getItem('wearnav-token'));
  assert.match(token || '', /^[0-9a-f]{32}$/, `the token kept in localStorage "wearnav-token" (got ${token})`);
});

step('guidance', ['pairing'], `Start guides to ${DESTINATION}: the route is shown and its first words said`, 95000, async () => {
  // What the feedback agent says before the page is on the bridge's socket is lost (the
  // route's first words among it): Start only once the agent's keep-alive vibration
  // (once a second to an idle phone) has come back from the page, the whole way. News
  // of the phone ("Phone connected.") is said by the agent's other voices, not the phone's.
  await waitFor('a vibration the feedback agent asked for, acknowledged by the page', () => acks('vibrated').length > 0, 20000);
  const select = page.getByLabel('Destination');
  await waitFor(`an option "${DESTINATION}" in the Destination list`, () =>
    select.evaluate((s, d) => [...s.options].some((o) => o.value === d), DESTINATION), 60000);
  await select.selectOption(DESTINATION);
  await page.getByRole('button', { name: 'Start', exact: true }).click();
  await waitFor(`a route message with status guiding and destination "${DESTINATION}"`, () =>
    framesIn.some((f) => f.msg.type === 'route' && f.msg.status === 'guiding' && f.msg.destination === DESTINATION), 30000);
  await waitFor(`the status region to say "Guiding to ${DESTINATION}"`, async () =>
    (await text('status')).includes(`Guiding to ${DESTINATION}`), 5000);
  // The route's first words, or the guidance that cut them off before they started: the
  // simulated user is not walking the route, and "Off the route: ..." interrupts (the
  // speech queue's rule), so which one the phone is asked to say depends on timing.
  await waitFor(`speechSynthesis asked to say "Route to ${DESTINATION}: ..." (or "Off the route: ..." interrupting it)`, async () =>
    (await calls()).speak.some((s) => isGuidance(s.text)), 10000);
});

step('door', ['guidance'], 'a door number typed at "At a door" reaches the localization and is answered aloud', 30000, async () => {
  await page.getByLabel('At a door: its number').fill(' 101 ');
  await page.getByRole('button', { name: 'I am at this door', exact: true }).click();
  await waitFor('a command frame {verb: "door", number: "101"} sent by the page', () =>
    framesOut.some((f) => f.msg.type === 'command' && f.msg.verb === 'door' && f.msg.number === '101'), 5000);
  await waitFor('speechSynthesis asked to say "Door 101." (the compute agent took it)', async () =>
    (await calls()).speak.some((s) => s.text === 'Door 101.'), 20000);
});

step('place', ['door'], `a place's name typed at "Where I am" reaches the localization and is answered aloud`, 30000, async () => {
  const field = page.getByLabel('Where I am: a place\'s name');
  const button = page.getByRole('button', { name: 'I am near this place', exact: true });
  await waitFor(`"${PLACE}" among the names the "Where I am" field suggests (its datalist)`, () =>
    page.evaluate((p) => [...document.getElementById('place-labels').options].some((o) => o.value === p), PLACE), 5000);
  const placeOnBus = (label) => monitor.some((m) =>
    m.line.key === `wearnav/${USER}/cmd/place` && m.line.body?.Place?.label === label);

  await field.fill(` ${PLACE} `);
  await button.click();
  await waitFor(`a command frame {verb: "place", label: "${PLACE}"} sent by the page`, () =>
    framesOut.some((f) => f.msg.type === 'command' && f.msg.verb === 'place' && f.msg.label === PLACE), 5000);
  await waitFor(`a Place command with label "${PLACE}" on cmd/place`, () => placeOnBus(PLACE), 5000);
  await waitFor(`speechSynthesis asked to say "Near ${PLACE}." (the compute agent took it)`, async () =>
    (await calls()).speak.some((s) => s.text === `Near ${PLACE}.`), 20000);

  await field.fill('the moon');
  await button.click();
  await waitFor('a Place command with label "the moon" on cmd/place', () => placeOnBus('the moon'), 5000);
  await waitFor('speechSynthesis asked to say "I do not know a place called the moon..."', async () =>
    (await calls()).speak.some((s) => s.text.startsWith('I do not know a place called the moon')), 20000);
});

step('haptics', ['guidance'], 'the phone vibrates what the feedback agent asks, and feedback/applied reports it at the page\'s time', 30000, async () => {
  const match = await waitFor('a navigator.vibrate call with the pattern of a received vibrate message', async () => {
    const made = (await calls()).vibrate;
    const asked = framesIn.filter((f) => f.msg.type === 'vibrate');
    return made.find((c) => asked.some((f) => isDeepStrictEqual(f.msg.pattern, c.pattern)));
  }, 10000);
  assert.ok(match);

  // feedback/applied carries no request id: the ack it reports is the one at its time
  const rumble = await waitFor('feedback/applied from device "phone" with a Rumble, at the time the page acked a vibrate (within 50 ms: the bridge takes the clock offset of the page out)', () => {
    const vibrated = acks('vibrated');
    for (const body of appliedFromPhone().filter((b) => b.action?.Rumble)) {
      const nearest = vibrated.reduce((best, a) =>
        (!best || Math.abs(a.t * 1e6 - body.applied_ns) < Math.abs(best.t * 1e6 - body.applied_ns) ? a : best), null);
      if (nearest && Math.abs(nearest.t * 1e6 - body.applied_ns) <= 5e7) return { body, ack: nearest };
    }
    return null;
  }, 20000).catch(async (e) => {
    const mon = children.find((c) => c.label === 'monitor');
    const rumbles = appliedFromPhone().filter((b) => b.action?.Rumble);
    const extra = mon.exited || mon.spawnError ? describeExit(mon) : `${monitor.length} monitor lines; phone rumbles applied: ${JSON.stringify(rumbles.slice(-3))}; vibrated acks: ${JSON.stringify(acks('vibrated').slice(-3))}`;
    e.message += `\n${extra}`;
    throw e;
  });
  assert.ok(framesIn.some((f) => f.msg.type === 'vibrate' && f.msg.id === rumble.ack.id), `ack ${rumble.ack.id} answers a vibrate request`);

  const route = framesIn.find((f) => f.msg.type === 'say' && isGuidance(f.msg.text));
  assert.ok(route, `a say message "Route to ${DESTINATION}: ..." or "Off the route: ..." reached the page\n${await seen()}`);
  const started = await waitFor(`the page acking "started" for say ${route.msg.id}`, () =>
    acks('started').find((a) => a.id === route.msg.id), 5000);
  const spoken = await waitFor(`feedback/applied SpeechStarted from device "phone" for "${route.msg.text}"`, () =>
    appliedFromPhone().find((b) => b.action?.SpeechStarted?.text === route.msg.text), 5000);
  assert.ok(Math.abs(spoken.applied_ns - started.t * 1e6) <= 5e7,
    `SpeechStarted applied_ns ${spoken.applied_ns} within 50 ms of the page's started ack at ${started.t} ms`);
});

step('a11y', ['pairing'], 'the page has no serious accessibility violations and every control has its name', 20000, async () => {
  await page.addScriptTag({ path: path.join(here, 'node_modules/axe-core/axe.min.js') });
  const result = await page.evaluate(() => window.axe.run());
  const bad = result.violations.filter((v) => v.impact === 'serious' || v.impact === 'critical');
  assert.deepEqual(bad.map((v) => ({ id: v.id, impact: v.impact, help: v.help, nodes: v.nodes.map((n) => n.target.join(' ')) })), [],
    'axe-core: no serious or critical violations');
  const controls = [['combobox', 'Destination'], ['button', 'Start'], ['button', 'Where am I'], ['button', 'Repeat'],
    ['button', 'Stop guidance'], ['button', 'Mute'], ['textbox', 'At a door: its number'], ['button', 'I am at this door'],
    ['combobox', 'Where I am: a place\'s name'], ['button', 'I am near this place']];
  for (const [role, name] of controls) {
    const found = page.getByRole(role, { name, exact: true });
    assert.equal(await found.count(), 1, `exactly one ${role} named "${name}"`);
    assert.ok(await found.isVisible(), `the ${role} "${name}" is visible`);
  }
  assert.equal(await page.getByRole('button', { name: 'Mute', exact: true }).getAttribute('aria-pressed'), 'false');
  await page.screenshot({ path: path.join(artifacts, 'phone.png'), fullPage: true });
});

step('loss', ['pairing'], 'losing the bridge is shown and said; a restarted bridge is back without pairing again', 45000, async () => {
  const lostAt = Date.now();
  await stop(bridge.child, 5000);
  await waitFor('the alert region to say the connection to the backpack was lost', async () =>
    /connection to the backpack lost/i.test(await text('alert')), Math.max(1000, 5000 - (Date.now() - lostAt)));
  await waitFor('"Connection to the backpack lost." spoken', async () =>
    (await calls()).speak.some((s) => s.t >= lostAt && /connection to the backpack lost/i.test(s.text)), 2000);

  const backFrom = Date.now();
  const restarted = await startBridge(`127.0.0.1:${bridge.httpPort}`);
  bridge = restarted;
  await waitFor('the alert region to say "Connection back."', async () => /Connection back\./.test(await text('alert')), 20000);
  await waitFor('"Connection back." spoken', async () =>
    (await calls()).speak.some((s) => s.t >= backFrom && s.text === 'Connection back.'), 5000);
  assert.equal(await page.getByLabel('Pairing code').isVisible(), false, 'no pairing again after the restart');
  assert.deepEqual(pageErrors, [], 'no script errors in the page');
});
