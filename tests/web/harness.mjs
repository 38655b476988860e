// What the browser tests share: the command line, the server under test on a free port with a fresh store,
// Debian's headless Chromium through playwright-core (/usr/bin/chromium; no browser is downloaded), polling,
// and one exit path that saves the logs (and a screenshot on failure) and releases everything.

import { spawn } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const CHROMIUM = '/usr/bin/chromium';
const CHROMIUM_ARGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
                       '--disable-background-networking', '--disable-component-update', '--disable-sync'];
const here = path.dirname(fileURLToPath(import.meta.url));
const webRoot = path.resolve(here, '../../web');
const webPackage = path.join(webRoot, 'package.json');

/** A failed check: its message is the test's reason for failing. */
export class TestFailure extends Error {}

/** Throws a TestFailure with `message` unless `cond`. */
export function check(cond, message) {
  if (!cond) throw new TestFailure(message);
}

/** Polls `fn` (async) until it returns a truthy value; throws `message` after `timeoutMs`. */
export async function until(fn, timeoutMs, message, periodMs = 100) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new TestFailure(message);
    await new Promise((r) => setTimeout(r, periodMs));
  }
}

/** The options `--server PATH --artifacts DIR` of test `name` (exits 2 on bad usage), as absolute paths. */
export function parseArgs(name, argv = process.argv.slice(2)) {
  const usage = (message) => {
    console.error(`${name}: ${message}\nusage: node tests/web/${name}.mjs --server PATH_TO_SERVER --artifacts DIR`);
    process.exit(2);
  };
  const opts = {};
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (a === '--server' || a === '--artifacts') {
      if (i + 1 >= argv.length) usage(`${a} needs a value`);
      opts[a.slice(2)] = argv[++i];
    } else usage(`unknown argument ${a}`);
  }
  if (!opts.server) usage('--server is required');
  if (!opts.artifacts) usage('--artifacts is required');
  return { server: path.resolve(opts.server), artifacts: path.resolve(opts.artifacts) };
}

/** One browser test run: the server, the browser and the page it drives, released on every exit path. */
export class BrowserRun {
  /** A run of test `name` saving its logs as ARTIFACTS/`prefix`-server.log and -console.log, failing after `timeoutMs`. */
  constructor(name, { artifacts, prefix, timeoutMs }) {
    Object.assign(this, { name, artifacts, prefix, timeoutMs });
    this.step = 'setup';
    this.chromium = null;  // playwright-core's, once loaded
    this.server = null;
    this.serverExited = null;
    this.serverStderr = [];
    this.context = null;
    this.page = null;
    this.tempDirs = [];
    this.consoleLines = [];
    this.pageErrors = [];
  }

  /** Prints `message` prefixed with the test's name. */
  log(message) {
    console.log(`${this.name}: ${message}`);
  }

  /** A temporary folder removed when the run ends. */
  tempDir(label) {
    const d = fs.mkdtempSync(path.join(os.tmpdir(), `panelbass-${label}-`));
    this.tempDirs.push(d);
    return d;
  }

  /** Starts `serverPath serve --port 0 --store (fresh) --web (this checkout's web/) ...extraArgs` (a .mjs under this node); resolves with its base
   *  URL from the first stdout line "panelbass: serving http://HOST:PORT/". */
  startServer(serverPath, extraArgs = []) {
    check(fs.existsSync(serverPath), `no server binary at ${serverPath}`);
    const store = this.tempDir('ui-store');
    // --web: the UI of this checkout, whichever folder the binary was built from.
    const args = ['serve', '--port', '0', '--store', store, '--web', webRoot, ...extraArgs];
    const [command, argv] = serverPath.endsWith('.mjs') ? [process.execPath, [serverPath, ...args]] : [serverPath, args];
    return new Promise((resolve, reject) => {
      const server = spawn(command, argv, { stdio: ['ignore', 'pipe', 'pipe'] });
      this.server = server;
      this.serverExited = new Promise((r) => server.on('exit', (code, signal) => r({ code, signal })));
      let out = '';
      let resolved = false;
      const timer = setTimeout(() => reject(new TestFailure('no "panelbass: serving http://…" line on stdout within 15 s')), 15_000);
      server.on('error', (e) => {
        clearTimeout(timer);
        reject(new TestFailure(`cannot start ${serverPath}: ${e.message}`));
      });
      let errBuf = '';
      server.stderr.on('data', (d) => {
        errBuf += d;
        const lines = errBuf.split('\n');
        errBuf = lines.pop();
        this.serverStderr.push(...lines);
      });
      server.stdout.on('data', (d) => {
        if (resolved) return;
        out += d;
        const nl = out.indexOf('\n');
        if (nl < 0) return;
        const first = out.slice(0, nl);
        // "panelbass: serving http://127.0.0.1:PORT/" (anything after the address, e.g. "(store …)", is ignored)
        const m = first.match(/^panelbass: serving (http:\/\/[^\s/]+)\/?(\s|$)/);
        clearTimeout(timer);
        resolved = true;
        if (m) {
          this.log(`server at ${m[1]}/ (store ${store})`);
          resolve(`${m[1]}/`);
        } else reject(new TestFailure(`first stdout line is not "panelbass: serving http://HOST:PORT/": ${JSON.stringify(first)}`));
      });
      this.serverExited.then(({ code, signal }) => {
        if (resolved) {
          if (this.step !== 'done') this.pageErrors.push(`server exited during the test (code ${code}, signal ${signal})`);
          return;
        }
        clearTimeout(timer);
        reject(new TestFailure(`server exited before serving (code ${code}, signal ${signal})`));
      });
    });
  }

  /** Loads playwright-core (before anything is started: an unsupported Node makes it exit at once) and checks
   *  for Chromium. */
  async loadTools() {
    this.step = 'loading playwright-core';
    try {
      ({ chromium: this.chromium } = createRequire(webPackage)('playwright-core'));
    } catch (e) {
      throw new TestFailure(`playwright-core not usable from ${webPackage} on Node ${process.version} `
                            + `(run scripts/web_setup.sh): ${e.message}`);
    }
    check(fs.existsSync(CHROMIUM), `${CHROMIUM} not found (run scripts/web_setup.sh, which installs Debian's chromium)`);
  }

  /** Launches Chromium through playwright-core and loads `base`; checks every static file was served and uPlot
   *  loaded. Resolves with the page. */
  async openPage(base) {
    this.step = 'launching chromium';
    this.context = await this.chromium.launchPersistentContext(this.tempDir('ui-profile'), {
      executablePath: CHROMIUM, headless: true, args: CHROMIUM_ARGS,
      viewport: { width: 1440, height: 1000 }, timeout: 30_000,
    });
    const page = this.context.pages()[0] || await this.context.newPage();
    this.page = page;
    page.setDefaultTimeout(15_000);
    page.on('console', (m) => this.consoleLines.push(`[${m.type()}] ${m.text()}`));
    page.on('pageerror', (e) => this.pageErrors.push(`uncaught: ${e.message}`));
    const badStatic = [];
    page.on('response', (r) => {
      const u = new URL(r.url());
      if (r.status() >= 400 && !u.pathname.startsWith('/api/') && u.pathname !== '/favicon.ico') badStatic.push(`${r.status()} ${u.pathname}`);
    });
    this.step = 'loading the page';
    await page.goto(base, { waitUntil: 'load' });
    check(badStatic.length === 0, `static files not served: ${badStatic.join(', ')}`);
    check(await page.evaluate(() => typeof window.uPlot === 'function'), 'uPlot did not load (node_modules/uplot/dist/uPlot.iife.min.js)');
    return page;
  }

  async stopServer() {
    const server = this.server;
    if (!server || server.exitCode !== null || server.signalCode !== null) return;
    server.kill('SIGTERM');
    const timer = new Promise((r) => setTimeout(() => r('timeout'), 3000));
    if ((await Promise.race([this.serverExited, timer])) === 'timeout') {
      server.kill('SIGKILL');
      await this.serverExited;
    }
  }

  async cleanup() {
    try {
      if (this.context) await Promise.race([this.context.close(), new Promise((r) => setTimeout(r, 5000))]);
    } catch { /* already gone */ }
    await this.stopServer();
    try {
      fs.mkdirSync(this.artifacts, { recursive: true });
      fs.writeFileSync(path.join(this.artifacts, `${this.prefix}-server.log`), this.serverStderr.join('\n') + '\n');
      fs.writeFileSync(path.join(this.artifacts, `${this.prefix}-console.log`), this.consoleLines.join('\n') + '\n');
    } catch { /* best effort */ }
    for (const d of this.tempDirs) fs.rmSync(d, { recursive: true, force: true });
  }

  async finish(code, message) {
    clearTimeout(this.overall);
    if (code !== 0) {
      console.error(`${this.name}: FAIL ${this.step}: ${message}`);
      if (this.pageErrors.length) console.error(`${this.name}: page errors:\n  ${this.pageErrors.join('\n  ')}`);
      if (this.serverStderr.length) console.error(`${this.name}: last server stderr lines:\n  ${this.serverStderr.slice(-15).join('\n  ')}`);
      if (this.page) {
        const shot = path.join(this.artifacts, `${this.prefix}-failure.png`);
        try {
          fs.mkdirSync(this.artifacts, { recursive: true });
          await this.page.screenshot({ path: shot, fullPage: true, timeout: 5000 });
          console.error(`${this.name}: screenshot of the failure: ${shot}`);
        } catch { /* no screenshot */ }
      }
    } else this.log(message);
    await this.cleanup();
    process.exit(code);
  }

  /** Runs `main(run)`; exits 0 with PASS, or 1 with "NAME: FAIL <step>: <reason>" (also on the overall timeout). */
  run(main) {
    this.overall = setTimeout(() => this.finish(1, `timed out after ${this.timeoutMs / 1000} s`), this.timeoutMs);
    // Whatever ends the process (a dependency may call process.exit), the server does not outlive it.
    process.on('exit', () => this.server?.kill('SIGKILL'));
    this.loadTools().then(() => main(this)).then(
      () => {
        this.step = 'done';
        return this.finish(0, 'PASS');
      },
      (e) => this.finish(1, e instanceof TestFailure ? e.message : (e && e.stack) || String(e)),
    );
  }
}
