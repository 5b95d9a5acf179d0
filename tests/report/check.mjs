// Drives headless Chromium (Debian's /usr/bin/chromium) over roks's
// report.html files: run by tests/report_browser.rs with a spec file.
//
//   node check.mjs SPEC.json
//
// SPEC: { "shots": DIR, "folders": [{ "name", "dir", "views": [...],
// "hover": true|false, "fit": MODEL (a folder with fit_MODEL.json),
// "mueller": true, "spectral_trace": true }] }. For each folder's DIR/report.html, opened from
// the file: no console error, no page error, no request but the file
// itself; every view in `views` drawn (a Plotly plot with its SVG or
// canvas, or a table); a screenshot of each view in SHOTS/NAME-VIEW.png;
// with `hover`, the last incidence, azimuth and wavelength picked, a cell
// of the hemisphere map hovered with the mouse, and the value and standard
// error the page shows equal to brdf.csv's, as printed (read here from the
// file, independently of the page); with `fit`, the model drawn over its
// table (in-plane, dashed, in the table's colour; the hemisphere map's
// model cell hovered shows fit_MODEL.json's value for it); with `mueller`,
// m00 on a log scale; with `spectral_trace`, the beam view against the
// wavelength equal to summary.json's spectra. Prints one JSON line per
// folder and exits 1 after every folder if any check failed.
import { chromium } from 'playwright-core';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const spec = JSON.parse(fs.readFileSync(process.argv[2], 'utf8'));
fs.mkdirSync(spec.shots, { recursive: true });
const userData = fs.mkdtempSync(path.join(os.tmpdir(), 'roks-chromium-'));
const browser = await chromium.launchPersistentContext(userData, {
  executablePath: process.env.ROKS_CHROMIUM || '/usr/bin/chromium',
  headless: true,
  args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update', '--disable-sync', '--enable-unsafe-swiftshader'],
  viewport: { width: 1280, height: 900 },
});
let failed = false;
function fail(folder, what) {
  console.log(JSON.stringify({ folder, error: what }));
  failed = true;
}

// The rows of a CSV text as objects of strings (the printed digits).
function csv(text) {
  const lines = text.split('\n').filter((l) => l.length);
  const head = lines[0].split(',');
  return lines.slice(1).map((l) => Object.fromEntries(l.split(',').map((v, i) => [head[i], v])));
}
function distinct(rows, key) {
  return rows[0][key] === undefined ? [undefined] : [...new Set(rows.map((r) => r[key]))];
}

for (const f of spec.folders) {
  const file = path.resolve(f.dir, 'report.html');
  const url = pathToFileURL(file).href;
  const page = await browser.newPage();
  const errors = [];
  const requests = [];
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('request', (r) => { if (r.url() !== url) requests.push(r.url()); });
  await page.route('**/*', (route) => (route.request().url() === url ? route.continue() : route.abort()));
  const t0 = Date.now();
  await page.goto(url);
  try {
    const broken = new Promise((_, reject) => page.on('pageerror', reject));
    await Promise.race([page.waitForSelector('body[data-ready="1"]', { timeout: 120000 }), broken]);
  } catch (e) {
    fail(f.name, 'the page never got ready: ' + errors.join(' | '));
    continue;
  }
  const loadMs = Date.now() - t0;
  const views = (await page.getAttribute('body', 'data-views')).split(' ');
  for (const v of f.views) {
    if (!views.includes(v)) { fail(f.name, 'view ' + v + ' missing; the page has ' + views.join(' ')); continue; }
    const drawn = await page.evaluate((v) => {
      const s = document.getElementById('view-' + v);
      const plots = [...s.querySelectorAll('.js-plotly-plot')];
      const ok = plots.length > 0 && plots.every((p) => p.querySelector('.main-svg') && (p.querySelector('.plot *, .gl-container canvas, canvas, .barlayer *, .heatmaplayer *, .scatterlayer *')));
      return ok || (plots.length === 0 && !!s.querySelector('table, img, p'));
    }, v);
    if (!drawn) fail(f.name, 'view ' + v + ' not drawn');
    await page.locator('#view-' + v).screenshot({ path: path.join(spec.shots, f.name + '-' + v + '.png') });
  }
  // A folder with fits draws each model over its table.
  const fits = await page.evaluate(() => !!document.querySelector('#plot-fits .scatterlayer .trace'));
  if (f.name === 'mueller' && !fits) fail(f.name, 'the fit is not drawn over its table');
  let hover = null;
  if (f.hover) {
    const rows = csv(fs.readFileSync(path.join(f.dir, 'brdf.csv'), 'utf8'));
    const thetas = distinct(rows, 'theta_i_deg'), phis = distinct(rows, 'phi_i_deg'), wls = distinct(rows, 'wavelength_um');
    // Pick the last of each, as a user does.
    for (const [id, n] of [['pick-theta', thetas.length], ['pick-phi', phis.length], ['pick-wl', wls.length]]) {
      await page.selectOption('#' + id, String(n - 1));
    }
    const block = rows.filter((r) => r.theta_i_deg === thetas.at(-1) && r.phi_i_deg === phis.at(-1) && r.wavelength_um === wls.at(-1));
    // Hover a cell well off the pole with the mouse.
    const bars = page.locator('#plot-hemisphere .barlayer path');
    const n = await bars.count();
    const target = bars.nth(Math.floor((n * 2) / 3));
    await page.locator('#plot-hemisphere').scrollIntoViewIfNeeded();
    const box = await target.boundingBox();
    await page.mouse.move(box.x + box.width / 2 - 3, box.y + box.height / 2 - 3);
    await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2, { steps: 4 });
    await page.waitForFunction(() => document.getElementById('hemisphere-hover').dataset.cell !== undefined, null, { timeout: 10000 });
    const shown = await page.evaluate(() => ({ ...document.getElementById('hemisphere-hover').dataset, text: document.getElementById('hemisphere-hover').textContent }));
    const row = block[+shown.cell];
    hover = { cell: +shown.cell, shown: shown.value, csv: row.brdf, stderr: shown.stderr, csv_stderr: row.brdf_stderr, text: shown.text };
    if (shown.value !== row.brdf || shown.stderr !== row.brdf_stderr) fail(f.name, 'hovered cell ' + shown.cell + ' shows ' + shown.value + ' ± ' + shown.stderr + ', brdf.csv says ' + row.brdf + ' ± ' + row.brdf_stderr);
    if (!shown.text.includes(row.brdf)) fail(f.name, 'the hover text does not show the value: ' + shown.text);
    // The other controls redraw without error.
    await page.selectOption('#hemi-scale', '1');
    await page.check('#hemi-relerr');
    await page.uncheck('#hemi-empty');
    await page.locator('#view-hemisphere').screenshot({ path: path.join(spec.shots, f.name + '-hemisphere-picked.png') });
  }
  // A folder with a fit (`fit`: the model): the model drawn over its
  // table, dashed in the in-plane curves in its table's colour, and in the
  // hemisphere map, where the hovered cell shows the model's value, equal
  // (to the report's 6 digits) to the one fit-model wrote for that cell.
  let model = null;
  if (f.fit) {
    const doc = JSON.parse(fs.readFileSync(path.join(f.dir, 'fit_' + f.fit + '.json'), 'utf8'));
    const rows = csv(fs.readFileSync(path.join(f.dir, 'brdf.csv'), 'utf8'));
    const thetas = distinct(rows, 'theta_i_deg');
    for (const id of ['pick-phi', 'pick-wl']) await page.selectOption('#' + id, '0');
    await page.selectOption('#pick-theta', '0');
    await page.uncheck('#hemi-relerr');
    const inplane = await page.evaluate((m) => {
      const data = document.getElementById('plot-inplane').data;
      const dashed = data.filter((t) => t.line && t.line.dash && t.line.dash !== 'solid' && t.name.endsWith(': ' + m + ' model'));
      const table = data.find((t) => t.name === dashed[0]?.name.split(':')[0]);
      return { dashed: dashed.length, colour: dashed[0]?.line.color, table: table?.line.color, points: dashed[0]?.y.filter((y) => y > 0).length };
    }, f.fit);
    if (!(inplane.dashed >= 1 && inplane.points > 10)) fail(f.name, 'no dashed ' + f.fit + ' model in the in-plane curves: ' + JSON.stringify(inplane));
    if (inplane.colour !== inplane.table) fail(f.name, 'the in-plane model is not in its table\'s colour: ' + JSON.stringify(inplane));
    // The fit's largest residual off the pole (band >= 8): its cell.
    const r = doc.fits.flatMap((x) => x.largest_residuals).find((x) => x.band >= 8) || doc.fits[0].largest_residuals[0];
    const ti = thetas.findIndex((t) => +t === r.theta_i_deg);
    const block = rows.filter((x) => x.theta_i_deg === thetas[ti]);
    const flat = block.findIndex((x) => +x.band === r.band && +x.cell === r.cell);
    await page.selectOption('#pick-theta', String(ti));
    await page.selectOption('#hemi-show', '1');
    const which = await page.evaluate((m) => [...document.getElementById('hemi-model').options].findIndex((o) => o.text.startsWith(m + ' (')), f.fit);
    await page.selectOption('#hemi-model', String(which));
    await page.evaluate(() => { delete document.getElementById('hemisphere-hover').dataset.cell; });
    await page.locator('#plot-hemisphere').scrollIntoViewIfNeeded();
    // A point inside the cell's drawn sector (its bounding box's centre may
    // lie in a neighbour): of a 9 x 9 grid over the box, the inside point
    // nearest the inside points' mean, in the viewport's pixels.
    const inside = (k) => page.evaluate((k) => {
      const path = document.querySelectorAll('#plot-hemisphere .barlayer path')[k];
      const b = path.getBBox(), m = path.getScreenCTM();
      const inside = [];
      for (let a = 1; a < 10; a++) for (let c = 1; c < 10; c++) {
        const p = new DOMPoint(b.x + (a * b.width) / 10, b.y + (c * b.height) / 10);
        if (path.isPointInFill(p)) inside.push(p);
      }
      const mx = inside.reduce((s, p) => s + p.x, 0) / inside.length, my = inside.reduce((s, p) => s + p.y, 0) / inside.length;
      const p = inside.sort((u, v) => Math.hypot(u.x - mx, u.y - my) - Math.hypot(v.x - mx, v.y - my))[0].matrixTransform(m);
      return { x: p.x, y: p.y };
    }, k);
    // Twice: the first hover may change the text above the map.
    for (let pass = 0; pass < 2; pass++) {
      const at = await inside(flat);
      await page.mouse.move(at.x - 2, at.y - 2);
      await page.mouse.move(at.x, at.y, { steps: 4 });
      await page.waitForTimeout(200);
    }
    // The cell under the mouse at last (an earlier step may cross others).
    await page.waitForFunction((k) => document.getElementById('hemisphere-hover').dataset.cell === String(k), flat, { timeout: 10000 }).catch(() => {});
    const shown = await page.evaluate(() => ({ ...document.getElementById('hemisphere-hover').dataset, text: document.getElementById('hemisphere-hover').textContent }));
    model = { cell: +shown.cell, want_cell: flat, shown: shown.model, fit: r.model, residual: shown.residual, text: shown.text };
    if (+shown.cell !== flat) fail(f.name, 'hovered cell ' + shown.cell + ', not the residual\'s cell ' + flat);
    else if (!(Math.abs(+shown.model - r.model) <= 5.000001e-6 * Math.abs(r.model))) fail(f.name, 'the model shows ' + shown.model + ' in cell ' + flat + ', fit-model wrote ' + r.model);
    if (!shown.text.includes(f.fit + ' model ' + shown.model)) fail(f.name, 'the hover text does not show the model: ' + shown.text);
    await page.locator('#view-hemisphere').screenshot({ path: path.join(spec.shots, f.name + '-hemisphere-model.png') });
    await page.selectOption('#hemi-show', '2');
    await page.locator('#view-hemisphere').screenshot({ path: path.join(spec.shots, f.name + '-hemisphere-residual.png') });
    await page.locator('#view-inplane').screenshot({ path: path.join(spec.shots, f.name + '-inplane-model.png') });
  }
  // A Mueller folder: m00 on a log scale (its colours log10 of
  // mueller.csv's m00 in the picked block), m_ij / m00 linear.
  if (f.mueller) {
    const z = await page.evaluate(() => {
      const gd = document.getElementById('plot-polar-m00');
      const zs = gd.data[0].z.flat().filter((x) => x !== null);
      return { title: gd.layout.title.text, min: Math.min(...zs), max: Math.max(...zs), other: document.getElementById('plot-polar-m01').layout.title.text };
    });
    const p = await page.evaluate(() => [+document.getElementById('pick-theta').value]);
    const rows = csv(fs.readFileSync(path.join(f.dir, 'mueller.csv'), 'utf8'));
    const th = distinct(rows, 'theta_i_deg')[p[0]];
    const m00 = rows.filter((x) => x.theta_i_deg === th).map((x) => +x.m00).filter((x) => x > 0);
    const [lo, hi] = [Math.log10(Math.min(...m00)), Math.log10(Math.max(...m00))];
    if (z.title !== 'log10 m00 (1/sr)' || z.other !== 'm01/m00' || z.min < lo - 1e-12 || z.max > hi + 1e-12 || z.max < lo) fail(f.name, 'm00 is not on a log scale: ' + JSON.stringify({ z, lo, hi }));
    await page.locator('#view-polarisation').screenshot({ path: path.join(spec.shots, f.name + '-polarisation-log.png') });
  }
  // A spectral trace: each beam position's reflectance against the
  // wavelength, summary.json's spectrum.
  if (f.spectral_trace) {
    const summary = JSON.parse(fs.readFileSync(path.join(f.dir, 'summary.json'), 'utf8'));
    const drawn = await page.evaluate(() => {
      const gd = document.getElementById('plot-beam');
      return { x: gd.layout.xaxis.title.text, traces: gd.data.map((t) => ({ name: t.name, x: t.x, y: t.y })), picked: [...document.getElementById('beam-positions').selectedOptions].map((o) => +o.value) };
    });
    if (drawn.x !== 'wavelength (µm)' || drawn.traces.length !== drawn.picked.length || !drawn.picked.length) fail(f.name, 'the beam view is not against wavelength: ' + JSON.stringify(drawn).slice(0, 300));
    drawn.picked.forEach((q, c) => {
      const sp = summary.sources[q].spectrum;
      const t = drawn.traces[c];
      if (JSON.stringify(t.x) !== JSON.stringify(sp.map((w) => w.wavelength_um)) || JSON.stringify(t.y) !== JSON.stringify(sp.map((w) => w.reflectance))) fail(f.name, 'position ' + q + ': the curve is not summary.json\'s spectrum');
    });
    model = { positions: drawn.picked, wavelengths: drawn.traces[0]?.x.length };
  }
  if (errors.length) fail(f.name, 'console errors: ' + errors.join(' | '));
  if (requests.length) fail(f.name, requests.length + ' requests besides the file: ' + requests.slice(0, 5).join(' '));
  const bytes = fs.statSync(file).size;
  console.log(JSON.stringify({ folder: f.name, bytes, load_ms: loadMs, views: views.length, hover, model }));
  await page.close();
}
console.log(JSON.stringify({ browser: browser.browser() ? browser.browser().version() : 'chromium' }));
await browser.close();
fs.rmSync(userData, { recursive: true, force: true });
process.exit(failed ? 1 : 0);
