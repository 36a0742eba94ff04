// Benchmark: haptic intent -> navigator.vibrate on the phone page, on loopback.
//
//     cargo build --bins && node tests/browser/phone-latency.mjs      # from the repository root
//
// Chain: publish_intents.py puts a haptic intent (and a clear hazard) on the bus ->
// feedback agent (--haptic phone) -> phone/haptic -> phone bridge -> WebSocket -> the
// page in headless Chromium calls navigator.vibrate. The page's clock
// (performance.timeOrigin + performance.now()) and the publisher's (time.time_ns()) are
// the same machine's wall clock, so the latency is the vibrate call's time minus the
// intent's capture stamp. Intents alternate left and right, so every one is a new
// pattern (left: one unbroken vibration; right: 60 ms on, 40 ms off).
//
// WEARNAV_BIN_DIR (default target/debug; use target/release for release figures),
// WEARNAV_PYTHON (default target/pyenv/bin/python, else python3: eclipse-zenoh),
// WEARNAV_CHROMIUM (default /usr/bin/chromium), PHONE_BENCH_INTENTS (default 1000),
// PHONE_BENCH_HZ (default 30). Prints n, p50, p99 and max in ms; exit code 1 when the
// chain broke (fewer than 99 % of the intents reached the page).

import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import readline from 'node:readline';
import { fileURLToPath } from 'node:url';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const binDir = path.resolve(root, process.env.WEARNAV_BIN_DIR || 'target/debug');
const venvPython = path.join(root, 'target/pyenv/bin/python');
const python = process.env.WEARNAV_PYTHON || (fs.existsSync(venvPython) ? venvPython : 'python3');
const chromiumPath = process.env.WEARNAV_CHROMIUM || '/usr/bin/chromium';
const count = Number(process.env.PHONE_BENCH_INTENTS || 1000);
const hz = Number(process.env.PHONE_BENCH_HZ || 30);
const USER = `phone-bench-${process.pid}`;
const CODE = '482913';

const children = [];
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
process.on('exit', () => {
  for (const c of children) if (c.exitCode === null) try { c.kill('SIGKILL'); } catch (e) { /* gone */ }
});

function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.once('error', reject);
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

/** Spawn `program`; `onLine` gets its stdout lines; stderr is kept for a failure. */
function run(program, args, onLine, env = {}) {
  const child = spawn(program, args, { cwd: root, env: { ...process.env, ...env }, stdio: ['ignore', 'pipe', 'pipe'] });
  child.stderrText = '';
  child.stderr.on('data', (d) => { child.stderrText = (child.stderrText + d).slice(-4000); });
  readline.createInterface({ input: child.stdout }).on('line', (l) => onLine?.(l));
  children.push(child);
  return child;
}

async function until(what, check, ms) {
  const end = Date.now() + ms;
  while (Date.now() < end) {
    const got = await check();
    if (got) return got;
    await sleep(50);
  }
  throw new Error(`gave up after ${ms / 1000} s waiting for ${what}`);
}

function quantile(sorted, q) {
  return sorted[Math.min(sorted.length, Math.max(1, Math.ceil(q * sorted.length))) - 1];
}

async function main() {
  const { chromium } = await import('playwright-core');
  const port = await freePort();
  const stateDir = fs.mkdtempSync(path.join(os.tmpdir(), 'wearnav-phone-bench-'));
  const userDir = fs.mkdtempSync(path.join(os.tmpdir(), 'wearnav-chromium-'));
  let context = null;
  // The folders are removed however the run ends, a bridge or a browser that does not
  // start included.
  try {
    const bus = ['--user', USER, '--no-multicast'];
    let url = null;
    run(path.join(binDir, 'phone-bridge'), [...bus, '--listen', `tcp/127.0.0.1:${port}`, '--state-dir', stateDir,
      '--http', '127.0.0.1:0'], (l) => { url ??= l.match(/^url: (http:\/\/\S+)/)?.[1] ?? null; },
    { WEARNAV_PAIRING_CODE: CODE });
    await until('the bridge to print its url', () => url, 30000);
    run(path.join(binDir, 'feedback-agent'), [...bus, '--connect', `tcp/127.0.0.1:${port}`, '--haptic', 'phone']);

    context = await chromium.launchPersistentContext(userDir, {
      executablePath: chromiumPath,
      headless: true,
      args: ['--headless', '--no-sandbox', '--disable-gpu', '--no-first-run', '--disable-background-networking'],
    });
    await context.addInitScript(() => {
      const made = [];
      window.__vibrations = made;
      Object.defineProperty(navigator, 'vibrate', {
        configurable: true,
        value: (pattern) => {
          made.push({ at_ms: performance.timeOrigin + performance.now(), pattern: [...pattern] });
          return true;
        },
      });
    });
    const page = context.pages()[0] || (await context.newPage());
    await page.goto(url);
    await page.getByLabel('Pairing code').fill(CODE);
    await page.getByRole('button', { name: 'Pair', exact: true }).click();
    await until('the page to connect', async () => /connected/i.test(await page.locator('#connection').textContent()), 15000);
    await page.locator('body').click(); // the touch a browser wants before vibrating

    const captures = [];
    const publisher = run(python, ['tests/browser/publish_intents.py', '--user', USER, '--connect',
      `tcp/127.0.0.1:${port}`, '--count', String(count), '--hz', String(hz)], (l) => captures.push(JSON.parse(l)),
    { PYTHONPATH: path.join(root, 'schemas/python') });
    const code = await new Promise((r) => publisher.on('exit', r));
    if (code !== 0) throw new Error(`publish_intents.py failed (${code}): ${publisher.stderrText}`);
    await sleep(500);
    const made = await page.evaluate(() => window.__vibrations);

    // Each intent's vibration: the first call after its capture, before the next one's,
    // with its side's pattern (a renewal or keep-alive would repeat the previous one).
    const lat = [];
    let v = 0;
    for (let k = 0; k < captures.length; k++) {
      const at = captures[k].capture_ns / 1e6;
      const next = k + 1 < captures.length ? captures[k + 1].capture_ns / 1e6 : Infinity;
      const left = captures[k].side === 'left';
      while (v < made.length && made[v].at_ms < at) v++;
      for (let w = v; w < made.length && made[w].at_ms < next; w++) {
        const p = made[w].pattern;
        if (left ? p.length === 1 && p[0] > 0 : p[0] === 60 && p[1] === 40) {
          lat.push(made[w].at_ms - at);
          break;
        }
      }
    }
    lat.sort((a, b) => a - b);
    const fmt = (x) => x.toFixed(2);
    console.log(`phone latency: ${captures.length} intents at ${hz} Hz, ${made.length} navigator.vibrate calls, ${lat.length} matched (binaries: ${path.relative(root, binDir)})`);
    if (lat.length) {
      console.log(`intent capture -> navigator.vibrate: p50 ${fmt(quantile(lat, 0.5))} ms, p99 ${fmt(quantile(lat, 0.99))} ms, max ${fmt(lat[lat.length - 1])} ms`);
    }
    if (lat.length < 0.99 * count) {
      console.error(`only ${lat.length} of ${count} intents reached navigator.vibrate`);
      process.exitCode = 1;
    }
  } finally {
    await context?.close();
    for (const c of children) c.kill('SIGTERM');
    fs.rmSync(userDir, { recursive: true, force: true });
    fs.rmSync(stateDir, { recursive: true, force: true });
  }
}

main().catch((e) => {
  console.error(`phone latency: ${e.message}`);
  for (const c of children) if (c.stderrText) console.error(`--- ${c.spawnargs[0]}:\n${c.stderrText}`);
  process.exit(1);
});
