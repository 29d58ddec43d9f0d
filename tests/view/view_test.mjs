// The 3D view in a real browser: Debian's chromium, headless, WebGL through SwiftShader, driven
// by puppeteer-core. For one scene it merges the test's input paths with the real `hgraph`
// binary, writes the view, opens it from file:// and checks what a user would see: the page
// becomes ready with no console error and no request beyond the file, a WebGL context exists,
// the merged path's colours are drawn where the page's camera projects its stretches (and are
// gone when the merged path is hidden), the robot moves between two animation times, the
// legend's numbers are the result's, and the chart has one point per reported objective.
// Screenshots are kept in --artifacts.
//
// Usage: node view_test.mjs --hgraph BIN --npm DIR --chromium BIN --scene S --paths P
//            --work DIR --artifacts DIR --name NAME [--min-share F] [--min-sources N]
//            [--expect-chart 0|1] [--expect-clearance 0|1] [-- extra merge flags]
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import zlib from 'node:zlib';

const argv = process.argv.slice(2);
const extra = argv.includes('--') ? argv.slice(argv.indexOf('--') + 1) : [];
const opts = {};
for (let i = 0; i < argv.length && argv[i] !== '--'; i += 2) opts[argv[i].replace(/^--/, '')] = argv[i + 1];
for (const k of ['hgraph', 'npm', 'chromium', 'scene', 'paths', 'work', 'artifacts', 'name']) {
  if (!opts[k]) { console.error(`missing --${k}`); process.exit(2); }
}
const puppeteer = createRequire(path.join(opts.npm, 'package.json'))('puppeteer-core');

const failures = [];
function expect(condition, message) {
  if (!condition) failures.push(message);
  console.log((condition ? 'ok   ' : 'FAIL ') + message);
}

function run(...args) {
  const proc = spawnSync(opts.hgraph, args, { encoding: 'utf8' });
  if (proc.status !== 0) {
    console.error(proc.stdout, proc.stderr);
    throw new Error(`hgraph ${args.join(' ')} exited ${proc.status}`);
  }
  return proc.stdout;
}

// Decodes an 8-bit RGB(A), non-interlaced PNG (what Chromium's screenshots are).
function readPng(buffer) {
  let pos = 8;
  let width = 0, height = 0, bpp = 0;
  const idat = [];
  while (pos < buffer.length) {
    const length = buffer.readUInt32BE(pos);
    const kind = buffer.toString('ascii', pos + 4, pos + 8);
    const body = buffer.subarray(pos + 8, pos + 8 + length);
    pos += 12 + length;
    if (kind === 'IHDR') {
      width = body.readUInt32BE(0);
      height = body.readUInt32BE(4);
      if (body[8] !== 8 || body[12] !== 0 || (body[9] !== 2 && body[9] !== 6)) throw new Error('unexpected PNG format');
      bpp = body[9] === 6 ? 4 : 3;
    } else if (kind === 'IDAT') {
      idat.push(body);
    }
  }
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * bpp;
  const rgb = new Uint8Array(width * height * 3);
  let prev = new Uint8Array(stride);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)];
    const line = Uint8Array.from(raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1)));
    for (let i = 0; i < stride; ++i) {
      const a = i >= bpp ? line[i - bpp] : 0;
      const b = prev[i];
      const c = i >= bpp ? prev[i - bpp] : 0;
      let p = 0;
      if (filter === 1) p = a;
      else if (filter === 2) p = b;
      else if (filter === 3) p = (a + b) >> 1;
      else if (filter === 4) {
        const q = a + b - c;
        const pa = Math.abs(q - a), pb = Math.abs(q - b), pc = Math.abs(q - c);
        p = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      line[i] = (line[i] + p) & 255;
    }
    for (let x = 0; x < width; ++x) for (let k = 0; k < 3; ++k) rgb[(y * width + x) * 3 + k] = line[x * bpp + k];
    prev = line;
  }
  return { width, height, rgb };
}

function hexRgb(hex) {
  const v = parseInt(hex.slice(1), 16);
  return [(v >> 16) & 255, (v >> 8) & 255, v & 255];
}

// True if a pixel within `r` of (x, y) has colour `rgb` (antialiased edges aside).
function colourNear(image, x, y, rgb, r = 2, tolerance = 20) {
  for (let dy = -r; dy <= r; ++dy) {
    for (let dx = -r; dx <= r; ++dx) {
      const px = Math.round(x) + dx, py = Math.round(y) + dy;
      if (px < 0 || py < 0 || px >= image.width || py >= image.height) continue;
      const o = (py * image.width + px) * 3;
      if (Math.abs(image.rgb[o] - rgb[0]) <= tolerance && Math.abs(image.rgb[o + 1] - rgb[1]) <= tolerance &&
          Math.abs(image.rgb[o + 2] - rgb[2]) <= tolerance) return true;
    }
  }
  return false;
}

function sameNumber(a, b) {
  if (b === undefined || b === null) return a === null || Number.isNaN(a);
  return Math.abs(a - b) <= 1e-9 * Math.max(1, Math.abs(b));
}

async function main() {
  fs.mkdirSync(opts.work, { recursive: true });
  fs.mkdirSync(opts.artifacts, { recursive: true });
  const resultFile = path.join(opts.work, `${opts.name}-result.json`);
  const viewFile = path.join(opts.work, `${opts.name}-view.html`);
  run('merge', '--scene', opts.scene, '--paths', opts.paths, '--out', resultFile, '--quiet', ...extra);
  run('view', '--scene', opts.scene, '--paths', opts.paths, '--result', resultFile, '--out', viewFile);
  const result = JSON.parse(fs.readFileSync(resultFile, 'utf8'));
  console.log(`view: ${viewFile}, ${(fs.statSync(viewFile).size / 1024).toFixed(0)} KiB`);

  const browser = await puppeteer.launch({
    executablePath: opts.chromium,
    headless: true,
    args: ['--headless=new', '--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader',
           '--enable-unsafe-swiftshader', '--hide-scrollbars', '--mute-audio'],
    defaultViewport: { width: 1200, height: 800, deviceScaleFactor: 1 },
  });
  try {
    const page = await browser.newPage();
    const consoleErrors = [];
    const foreign = [];
    page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
    page.on('pageerror', (e) => consoleErrors.push(String(e)));
    page.on('request', (r) => { if (!r.url().startsWith('file://')) foreign.push(r.url()); });
    const url = pathToFileURL(viewFile).href;
    await page.goto(url, { waitUntil: 'load' });
    await page.waitForFunction(() => window.hgraphView && window.hgraphView.ready, { timeout: 60000 });
    const state = await page.evaluate(() => ({
      error: window.hgraphView.error,
      webgl: window.hgraphView.webgl,
      context: !!(document.getElementById('view').getContext('webgl2') ||
                  document.getElementById('view').getContext('webgl')),
    }));
    expect(state.error === null, `the page built its scene (${state.error})`);
    expect(state.webgl && state.context, 'a WebGL context was created');
    expect(foreign.length === 0, `no request beyond file:// (${foreign.join(', ')})`);

    // Legend: every number is the result's.
    const legend = await page.evaluate(() => [...document.querySelectorAll('#legend tr[data-path]')].map((tr) => ({
      name: tr.dataset.path,
      merged: tr.classList.contains('merged'),
      length: Number(tr.querySelector('.length').dataset.value),
      lengthText: tr.querySelector('.length').textContent,
      clearance: tr.querySelector('.clearance').dataset.value,
    })));
    const merged = legend.find((r) => r.merged);
    expect(merged && sameNumber(merged.length, result.quality.length),
           `legend: merged length ${merged && merged.length} = result ${result.quality.length}`);
    expect(merged && Math.abs(parseFloat(merged.lengthText) - result.quality.length) <= 1e-4 * result.quality.length,
           `legend: merged length shown as ${merged && merged.lengthText}`);
    const clearances = opts['expect-clearance'] === '1';
    if (clearances) {
      expect(result.quality.has_clearance && result.inputs.every((r) => !r.valid || r.quality.has_clearance),
             'the result reports every clearance (--report-inputs --report-clearance)');
    }
    if (result.quality.has_clearance) {
      expect(merged && sameNumber(Number(merged.clearance), result.quality.min_clearance),
             `legend: merged clearance ${merged && merged.clearance} = result ${result.quality.min_clearance}`);
    }
    for (const report of result.inputs) {
      const row = legend.find((r) => !r.merged && (r.name === report.name || r.name === `${report.name} (invalid)`));
      expect(row !== undefined, `legend has input ${report.name}`);
      if (row && report.valid) {
        expect(sameNumber(row.length, report.quality.length),
               `legend: ${report.name} length ${row.length} = result ${report.quality.length}`);
        if (report.quality.has_clearance) {
          expect(sameNumber(Number(row.clearance), report.quality.min_clearance),
                 `legend: ${report.name} clearance ${row.clearance} = result ${report.quality.min_clearance}`);
        }
      }
    }
    const objective = await page.evaluate(() => Number(document.getElementById('objective').dataset.value));
    expect(sameNumber(objective, result.objective), `legend: objective ${objective} = result ${result.objective}`);

    // Chart: one point per objective the merge reported during its post-optimization, and no
    // chart when it reported none (--optimize-ms 0).
    const reported = (result.progress || []).filter((p) => p.phase === 'optimize' && p.objective !== undefined);
    const dots = await page.evaluate(() => [...document.querySelectorAll('#chart circle.dot')].map((c) => Number(c.dataset.objective)));
    const chart = opts['expect-chart'] !== '0';
    expect(chart ? reported.length > 0 : reported.length === 0,
           `the result file kept ${reported.length} post-optimization events`);
    expect(dots.length === reported.length && dots.every((d, i) => sameNumber(d, reported[i].objective)),
           `chart: ${dots.length} points for ${reported.length} reported objectives`);
    if (!chart) expect(await page.$('#chart') === null, 'no chart without post-optimization events');

    await page.screenshot({ path: path.join(opts.artifacts, `${opts.name}.png`) });

    // The merged path's pixels: inputs hidden, so that a colour the merged path shares with the
    // input it follows can only come from the merged path.
    await page.evaluate(() => {
      for (const tr of document.querySelectorAll('#legend tr.input')) tr.querySelector('.show').click();
      window.hgraphView.setTime(0);
    });
    const stretches = await page.evaluate(() => window.hgraphView.mergedStretches().map((s) => {
      const [x, y, depth] = window.hgraphView.project(s.xyz);
      const hit = document.elementFromPoint(x, y);
      return { x, y, colour: s.colour, visible: depth < 1 && hit !== null && hit.id === 'view' };
    }));
    const visible = stretches.filter((s) => s.visible);
    // The merged path is coloured by where each stretch came from.
    const sources = new Set(stretches.map((s) => s.colour));
    const minSources = Number(opts['min-sources'] || 1);
    expect(sources.size >= minSources, `${sources.size} stretch colours (>= ${minSources}): ${[...sources].join(' ')}`);
    const shot = readPng(await page.screenshot({ path: path.join(opts.artifacts, `${opts.name}-merged.png`) }));
    const hits = visible.filter((s) => colourNear(shot, s.x, s.y, hexRgb(s.colour))).length;
    const share = hits / Math.max(visible.length, 1);
    const minShare = Number(opts['min-share'] || 0.8);
    expect(visible.length >= 3, `${visible.length} of ${stretches.length} merged stretches on screen`);
    expect(share >= minShare, `merged path drawn at ${hits} of ${visible.length} projected stretches (>= ${minShare})`);
    await page.evaluate(() => document.querySelector('#legend tr.merged .show').click());
    const hidden = readPng(await page.screenshot());
    const left = visible.filter((s) => colourNear(hidden, s.x, s.y, hexRgb(s.colour))).length;
    expect(left < 0.5 * hits, `hiding the merged path removes its colour (${left} of ${hits} left)`);
    await page.evaluate(() => document.querySelector('#legend tr.merged .show').click());

    // The robot moves: two animation times give different pictures around the robot.
    const at = async (t, file) => {
      const box = await page.evaluate((time) => {
        window.hgraphView.setTime(time);
        return window.hgraphView.robotScreenBox();
      }, t);
      return { box, image: readPng(await page.screenshot({ path: path.join(opts.artifacts, file) })) };
    };
    // The slider's thumb moves too: the control bar is left out.
    const bar = await page.$eval('#bar', (e) => { const r = e.getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; });
    const a = await at(0.2, `${opts.name}-t20.png`);
    const b = await at(0.8, `${opts.name}-t80.png`);
    const inside = (r, x, y, pad) => x >= r[0] - pad && x <= r[2] + pad && y >= r[1] - pad && y <= r[3] + pad;
    let changedNearRobot = 0;
    let changed = 0;
    for (let y = 0; y < a.image.height; ++y) {
      for (let x = 0; x < a.image.width; ++x) {
        const o = (y * a.image.width + x) * 3;
        const d = Math.abs(a.image.rgb[o] - b.image.rgb[o]) + Math.abs(a.image.rgb[o + 1] - b.image.rgb[o + 1]) +
                  Math.abs(a.image.rgb[o + 2] - b.image.rgb[o + 2]);
        if (d < 30 || inside(bar, x, y, 0)) continue;
        changed += 1;
        if (inside(a.box, x, y, 4) || inside(b.box, x, y, 4)) changedNearRobot += 1;
      }
    }
    expect(changedNearRobot > 100, `robot moved: ${changedNearRobot} pixels changed around its two poses (${changed} in all)`);
    expect(changed - changedNearRobot <= 0.02 * changed, `what changed is around the robot (${changed - changedNearRobot} pixels elsewhere)`);

    // The controls: play advances the slider.
    const before = await page.$eval('#time', (e) => Number(e.value));
    await page.evaluate(() => window.hgraphView.setTime(0));
    await page.click('#play');
    await page.waitForFunction(() => Number(document.getElementById('time').value) > 0, { timeout: 30000 });
    await page.click('#play');
    expect(before === 800, `slider followed setTime (${before})`);

    expect(consoleErrors.length === 0, `no console error (${consoleErrors.join(' | ')})`);
  } finally {
    await browser.close();
  }
  console.log(failures.length === 0 ? `${opts.name}: all checks passed` : `${opts.name}: ${failures.length} failed`);
  process.exit(failures.length === 0 ? 0 : 1);
}

main().catch((e) => { console.error(e); process.exit(1); });
