// What the browser tests share: the real agents as child processes (their output to
// target/browser-artifacts/), headless Chromium through playwright-core, waits that say
// what they expected and what they saw, and steps that run only if the ones they need
// passed. phone.test.mjs and monitor.test.mjs use it.
//
// WEARNAV_BIN_DIR (default target/debug) holds the agents' binaries; WEARNAV_PYTHON
// (default python3) is a Python with eclipse-zenoh, for schemas/python/monitor.py and
// send.py; WEARNAV_CHROMIUM (default /usr/bin/chromium) is the browser.

import assert from 'node:assert/strict';
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { test } from 'node:test';
import { fileURLToPath } from 'node:url';

export const here = path.dirname(fileURLToPath(import.meta.url));
export const root = path.resolve(here, '../..');
export const binDir = path.resolve(root, process.env.WEARNAV_BIN_DIR || 'target/debug');
export const python = process.env.WEARNAV_PYTHON || 'python3';
export const chromiumPath = process.env.WEARNAV_CHROMIUM || '/usr/bin/chromium';
export const artifacts = path.join(root, 'target/browser-artifacts');

export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** A free TCP port on loopback. */
export function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.once('error', reject);
    s.listen(0, '127.0.0.1', () => {
      const { port } = s.address();
      s.close(() => resolve(port));
    });
  });
}

/** The last `lines` lines of `file`. */
export function tail(file, lines = 15) {
  try {
    return fs.readFileSync(file, 'utf8').trimEnd().split('\n').slice(-lines).join('\n');
  } catch (e) {
    return `(no ${file})`;
  }
}

/**
 * One test file's processes, browser and budget. `budgetMs` bounds the whole file;
 * `seen` (async, returns text) says what the page and the bus looked like when a wait
 * fails; `prefix` names the file's artifacts (`<prefix>-<process>.stderr`).
 */
export function harness({ budgetMs, seen = async () => '', prefix = '' }) {
  const deadline = Date.now() + budgetMs;
  const children = [];
  const cleanups = [];
  const passed = new Set();
  const file = (name) => path.join(artifacts, prefix ? `${prefix}-${name}` : name);

  process.on('exit', () => {
    for (const c of children) if (!c.exited) try { c.kill('SIGKILL'); } catch (e) { /* gone */ }
  });

  /** Start `name`; stderr (and stdout unless `onStdout` takes it) go to artifacts. */
  function start(name, program, args, onStdout) {
    fs.mkdirSync(artifacts, { recursive: true });
    const errFile = file(`${name}.stderr`);
    const errFd = fs.openSync(errFile, 'w');
    const child = spawn(program, args, { cwd: root, stdio: ['ignore', 'pipe', errFd] });
    fs.closeSync(errFd);
    const outFile = fs.createWriteStream(file(`${name}.stdout`));
    let buffered = '';
    child.stdout.setEncoding('utf8');
    child.stdout.on('data', (chunk) => {
      outFile.write(chunk);
      if (!onStdout) return;
      buffered += chunk;
      const lines = buffered.split('\n');
      buffered = lines.pop();
      for (const line of lines) onStdout(line);
    });
    child.exited = null;
    child.spawnError = null;
    child.on('error', (e) => { child.spawnError = e; });
    child.on('exit', (code, signal) => { child.exited = { code, signal }; outFile.end(); });
    child.label = name;
    child.errFile = errFile;
    children.push(child);
    return child;
  }

  function describeExit(child) {
    if (child.spawnError) return `${child.label} could not start: ${child.spawnError.message}`;
    const { code, signal } = child.exited;
    return `${child.label} exited (code ${code}, signal ${signal}); its stderr ends:\n${tail(child.errFile)}`;
  }

  /** What stopped early, for a failure message. */
  function exits() {
    return children.filter((c) => c.exited || c.spawnError).map(describeExit).join('\n');
  }

  async function stop(child, ms = 3000) {
    if (!child || child.exited || child.spawnError) return;
    child.kill('SIGTERM');
    const end = Date.now() + ms;
    while (!child.exited && Date.now() < end) await sleep(50);
    if (!child.exited) {
      child.kill('SIGKILL');
      while (!child.exited && Date.now() < end + 2000) await sleep(50);
    }
  }

  /** Poll `check` until it returns something truthy; fail saying what was expected and
   * seen. No wait goes past the whole file's budget. */
  async function waitFor(expected, check, ms) {
    const end = Math.min(Date.now() + ms, deadline);
    for (;;) {
      const got = await check();
      if (got) return got;
      if (Date.now() > end) break;
      await sleep(100);
    }
    const why = end === deadline ? ` (the whole test's ${budgetMs / 1000} s ran out)` : '';
    assert.fail(`expected within ${ms / 1000} s${why}: ${expected}\nseen:\n${await seen()}`);
  }

  /** A test that runs only if the steps it `needs` (by key) passed. */
  function step(key, needs, name, ms, fn) {
    test(name, { timeout: ms + 5000 }, async () => {
      const first = needs.find((k) => !passed.has(k));
      if (first) assert.fail(`not run: it needs step "${first}", which did not pass`);
      await fn();
      passed.add(key);
    });
  }

  /** Fail now, saying what to do, if a binary or the browser is missing. */
  function requireBinaries(names) {
    const missing = names.map((b) => path.join(binDir, b)).filter((b) => !fs.existsSync(b));
    assert.ok(!missing.length, `missing binaries: ${missing.join(', ')}. Build them first (cargo build --workspace --bins) or point WEARNAV_BIN_DIR at them.`);
    assert.ok(fs.existsSync(chromiumPath), `no Chromium at ${chromiumPath}: install Debian's (apt-get install chromium) or set WEARNAV_CHROMIUM.`);
  }

  /** Headless Chromium with a fresh profile (closed and removed at the end). */
  async function launchChromium(contextOptions = {}) {
    const { chromium } = await import('playwright-core').catch((e) => {
      assert.fail(`cannot load playwright-core (${e.message}): run npm ci --prefix tests/browser`);
    });
    const userDir = fs.mkdtempSync(path.join(os.tmpdir(), 'wearnav-chromium-'));
    // Pushed before the launch, so a browser that fails to start leaves no profile behind;
    // cleanups run in reverse, so it is removed after the browser closed.
    cleanups.push(async () => fs.rmSync(userDir, { recursive: true, force: true }));
    const context = await chromium.launchPersistentContext(userDir, {
      executablePath: chromiumPath,
      headless: true,
      args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
        '--disable-background-networking', '--disable-component-update', '--disable-sync'],
      ...contextOptions,
    });
    cleanups.push(() => context.close());
    const page = context.pages()[0] || (await context.newPage());
    return { context, page };
  }

  /** Start the phone bridge (`args` without --http) on `httpAddress`; resolves once it
   * printed its address and pairing code. */
  function startBridge(name, args, httpAddress) {
    let url = null;
    let code = null;
    const child = start(name, path.join(binDir, 'phone-bridge'), [...args, '--http', httpAddress], (line) => {
      url ??= line.match(/^url: (http:\/\/\S+)/)?.[1] ?? null;
      code ??= line.match(/pairing code: (\d{6})\b/)?.[1] ?? null;
    });
    return waitFor('the bridge prints "url: http://127.0.0.1:<port>/" and "pairing code: <6 digits>" on stdout', () => {
      if (child.exited || child.spawnError) assert.fail(`the bridge stopped before printing its address: ${describeExit(child)}`);
      return url && code && { child, url, code, httpPort: Number(new URL(url).port) };
    }, 30000);
  }

  /** Close the browser, stop every process. For `after()`. */
  async function finish() {
    for (const c of cleanups.splice(0).reverse()) await c().catch(() => {});
    await Promise.all(children.map((c) => stop(c)));
  }

  return {
    deadline, children, passed, start, describeExit, exits, stop, waitFor, step, requireBinaries,
    launchChromium, startBridge, finish,
  };
}
