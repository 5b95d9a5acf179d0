// The interactive report of a roks result folder: every view drawn with
// Plotly.js from the data in the page. The library (script#roks-lib) and
// the data (script#roks-data, JSON) are gzip-compressed and base64-encoded
// in the page, and unpacked here by the browser (DecompressionStream). No
// network.
'use strict';
(async function () {
  async function gunzip(id) {
    const text = atob(document.getElementById(id).textContent.trim());
    const bytes = new Uint8Array(text.length);
    for (let k = 0; k < text.length; k++) bytes[k] = text.charCodeAt(k);
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'));
    return new Response(stream).text();
  }
  try {
    const lib = document.createElement('script');
    lib.textContent = await gunzip('roks-lib');
    document.head.append(lib);
    const data = JSON.parse(await gunzip('roks-data'));
    document.getElementById('app').textContent = '';
    draw(data);
  } catch (e) {
    document.getElementById('app').textContent = 'This report needs a current browser (with DecompressionStream): ' + e;
    throw e;
  }
})();

function draw(D) {
  const S = D.summary;
  const app = document.getElementById('app');
  const CONFIG = { displaylogo: false, responsive: true, showLink: false, showSendToCloud: false, showEditInChartStudio: false };
  // Ten distinct colours (Tableau 10), one per curve.
  const PALETTE = ['#4e79a7', '#f28e2b', '#e15759', '#76b7b2', '#59a14f', '#edc948', '#b07aa1', '#ff9da7', '#9c755f', '#bab0ac'];
  const views = [];

  function el(tag, attrs, ...kids) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (k === 'text') e.textContent = v;
      else if (k === 'class') e.className = v;
      else e.setAttribute(k, v);
    }
    for (const k of kids) e.append(k);
    return e;
  }
  // A number as the tables print it: 10 significant digits, `1.234567890e-1`.
  function fmt(x) {
    return x.toExponential(9).replace('e+', 'e');
  }
  function short(x) {
    if (x === null || x === undefined) return '';
    if (typeof x !== 'number') return String(x);
    if (x === 0) return '0';
    const a = Math.abs(x);
    return a >= 1e-3 && a < 1e5 ? String(+x.toPrecision(6)) : x.toExponential(4);
  }
  function table(head, rows) {
    const t = el('table');
    if (head.some((h) => h)) t.append(el('tr', {}, ...head.map((h) => el('th', { text: h }))));
    for (const r of rows) {
      t.append(el('tr', {}, ...r.map((c, i) => el('td', { class: typeof c === 'number' || i > 0 ? '' : 'key', text: short(c) }))));
    }
    return t;
  }
  const nav = el('nav');
  function section(id, title, note) {
    const s = el('section', { id: 'view-' + id, 'data-view': id });
    s.append(el('h2', { text: title }));
    if (note) s.append(el('p', { class: 'note', text: note }));
    app.append(s);
    nav.append(el('a', { href: '#view-' + id, text: title }));
    views.push(id);
    return s;
  }
  function plotDiv(id, cls) {
    return el('div', { id: 'plot-' + id, class: cls || 'plot' });
  }
  function select(id, label, options, onchange, multiple) {
    const s = el('select', { id: id });
    if (multiple) s.multiple = true;
    options.forEach((o, i) => s.append(el('option', { value: String(i), text: o })));
    s.addEventListener('change', onchange);
    return el('label', {}, label + ' ', s);
  }
  function checkbox(id, label, checked, onchange) {
    const c = el('input', { type: 'checkbox', id: id });
    c.checked = checked;
    c.addEventListener('change', onchange);
    return el('label', {}, c, ' ' + label);
  }
  function val(id) {
    return +document.getElementById(id).value;
  }
  function checked(id) {
    return document.getElementById(id).checked;
  }
  function range(n) {
    return Array.from({ length: n }, (_, i) => i);
  }
  function deg(x) {
    return short(x) + '°';
  }

  // ---- The Carlson cells over the hemisphere ----
  // Cell k of a block: its theta and phi bounds (degrees).
  function Cells(c) {
    this.c = c;
    this.n = c.theta_deg.length;
  }
  // A hemisphere map: bars of a polar plot, one per cell, radius theta.
  function hemisphereTraces(cells, values, opts) {
    const c = cells.c;
    const full = [], empty = [];
    const shown = opts.diverging ? (x) => Number.isFinite(x) : (x) => x > 0;
    for (let k = 0; k < cells.n; k++) (shown(values[k]) ? full : empty).push(k);
    const colour = full.map((k) => (opts.log ? Math.log10(values[k]) : values[k]));
    const bar = (ks) => ({
      type: 'barpolar',
      base: ks.map((k) => c.theta_lo_deg[k]),
      r: ks.map((k) => c.theta_hi_deg[k] - c.theta_lo_deg[k]),
      theta: ks.map((k) => (c.phi_lo_deg[k] + c.phi_hi_deg[k]) / 2),
      width: ks.map((k) => c.phi_hi_deg[k] - c.phi_lo_deg[k]),
      customdata: ks,
      marker: { line: { width: 0 } },
      hoverinfo: 'none',
    });
    const t = bar(full);
    t.marker.color = colour;
    t.marker.colorscale = 'Viridis';
    if (opts.diverging) Object.assign(t.marker, { colorscale: 'RdBu', cmin: -opts.range, cmax: opts.range });
    t.marker.colorbar = { title: { text: opts.unit }, thickness: 14 };
    const traces = [t];
    if (opts.empty && empty.length) {
      const e = bar(empty);
      e.marker.color = '#d33';
      e.name = 'no photon';
      traces.push(e);
    }
    return traces;
  }
  const POLAR_LAYOUT = {
    polar: {
      radialaxis: { range: [0, 90], ticksuffix: '°', angle: 0, tickfont: { size: 9 } },
      angularaxis: { direction: 'counterclockwise', rotation: 0, ticksuffix: '°' },
      bargap: 0,
    },
    margin: { t: 30, b: 30, l: 30, r: 30 },
    showlegend: false,
    height: 520,
  };
  // Values on a regular grid of the equal-area disc (r = 2 sin(theta/2)),
  // each pixel the value of the Carlson cell it falls in: a heatmap.
  function discGrid(cells, n) {
    const c = cells.c;
    const bands = new Map();
    for (let k = 0; k < cells.n; k++) {
      const key = c.theta_lo_deg[k];
      if (!bands.has(key)) bands.set(key, []);
      bands.get(key).push(k);
    }
    const list = [...bands.entries()].sort((a, b) => a[0] - b[0]);
    const rmax = Math.SQRT2;
    const xs = range(n).map((i) => -rmax + (2 * rmax * (i + 0.5)) / n);
    const idx = [];
    for (let j = 0; j < n; j++) {
      const row = [];
      for (let i = 0; i < n; i++) {
        const x = xs[i], y = xs[j], r = Math.hypot(x, y);
        if (r > rmax) { row.push(-1); continue; }
        const th = (2 * Math.asin(Math.min(1, r / 2)) * 180) / Math.PI;
        let b = list.findIndex(([lo], q) => th >= lo && (q + 1 === list.length || th < list[q + 1][0]));
        if (b < 0) b = list.length - 1;
        const ks = list[b][1];
        const ph = (Math.atan2(y, x) * 180) / Math.PI;
        let found = ks[ks.length - 1];
        for (const k of ks) {
          let p = ph;
          while (p < c.phi_lo_deg[k]) p += 360;
          while (p >= c.phi_lo_deg[k] + 360) p -= 360;
          if (p < c.phi_hi_deg[k]) { found = k; break; }
        }
        row.push(found);
      }
      idx.push(row);
    }
    return { xs, idx };
  }
  function discHeatmap(grid, value, opts) {
    const z = grid.idx.map((row) => row.map((k) => (k < 0 ? null : value(k))));
    return {
      type: 'heatmap', x: grid.xs, y: grid.xs, z: z, colorscale: opts.colorscale || 'Viridis',
      zmid: opts.zmid, showscale: true, colorbar: { thickness: 8, tickfont: { size: 8 }, len: 0.9 },
      hoverinfo: 'z',
    };
  }
  function discLayout(title) {
    return {
      title: { text: title, font: { size: 11 } }, margin: { t: 22, b: 4, l: 4, r: 4 },
      xaxis: { visible: false, scaleanchor: 'y' }, yaxis: { visible: false }, height: 210,
    };
  }

  // ---- The header ----
  app.append(el('h1', { text: document.title }));
  app.append(nav);

  if (D.kind === 'brdf') brdfViews();
  else traceViews();

  function describe(rows) {
    const s = section('description', 'The run');
    s.append(table(['', ''], rows));
    const files = S.content && S.content.files ? Object.entries(S.content.files) : [];
    if (files.length) s.append(table(['file the scene reads', 'sha256'], files.map(([f, h]) => [f, typeof h === 'string' ? h : JSON.stringify(h)])));
    s.append(el('p', { class: 'note', text: 'Times are left out of this report: two runs of the same result (a whole run and the merge of its shards) give the same report.' }));
  }

  function brdfViews() {
    const run = S.run;
    const [NT, NP, NL, NC] = D.shape;
    const wl = D.wl;
    run.theta_deg = D.theta;
    run.phi_deg = D.phi;
    const cells = new Cells(D.cell);
    const block = (i, j, l) => ((i * NP + j) * NL + l);
    // The fitted models drawn over their tables (fit_<model>.json of the
    // folder, evaluated by roks per Carlson cell and in-plane bin), each
    // with its own dash in the in-plane curves.
    const MODELS = D.products.fits.filter((f) => f.overlay);
    const DASHES = ['dash', 'dot', 'dashdot', 'longdash'];
    // The model `f`'s values at the picked incidence i, azimuth j and
    // wavelength l (`what`: 'cells' or 'inplane', `n` values each), or
    // null where it was not fitted.
    function modelAt(f, i, j, l, what, n) {
      const o = f.overlay;
      const q = o.theta.indexOf(i);
      if (j !== 0 || l !== o.lane || q < 0) return null;
      return o[what].slice(q * n, (q + 1) * n);
    }
    function where(f) {
      const o = f.overlay;
      return 'θi ' + o.theta.map((i) => deg(run.theta_deg[i])).join(', ') + (wl.length ? ' at ' + wl[o.lane] + ' µm' : '');
    }
    // A cell's projected solid angle (sr) from its bounds.
    function proj(k) {
      const c = D.cell, r = Math.PI / 180;
      const a = Math.cos(c.theta_lo_deg[k] * r), b = Math.cos(c.theta_hi_deg[k] * r);
      return ((c.phi_hi_deg[k] - c.phi_lo_deg[k]) * r * (a * a - b * b)) / 2;
    }
    // (table - model) / std. error per cell, as the fit weighs it: a cell
    // no photon left through has the error of one photon, 1 / (N proj).
    function residuals(v, se, m, n) {
      return v.map((x, k) => {
        const s = se[k] > 0 ? se[k] : n > 0 ? 1 / (n * proj(k)) : 0;
        return s > 0 ? (x - m[k]) / s : null;
      });
    }
    function fmtModel(x) {
      return x.toExponential(5).replace('e+', 'e');
    }
    const summaryAt = (i, j) => S.incidence[i * NP + j];
    describe([
      ['scene', S.name], ['scene file', S.scene], ['content sha256', S.content.scene_sha256],
      ['photons per incidence', run.photons_per_incidence], ['seed', run.seed], ['substrate material', D.material || 'in the scene file of the hash above (not found with that content here)'],
      ['incidence angles (deg)', run.theta_deg.join(', ')], ['light azimuths (deg)', run.phi_deg.join(', ')],
      ['wavelengths (µm)', wl.length ? wl.join(', ') : 'monochrome'],
      ['launch', run.launch], ['symmetry', run.symmetry], ['polarisation', JSON.stringify(run.polarisation)],
      ['Carlson bands', run.bands + ' (' + NC + ' cells)'], ['edges', S.edges], ['roks version', S.version],
    ]);

    // Reflectance table.
    {
      const s = section('reflectance-table', 'Reflectance, errors and losses');
      const rows = S.incidence.map((r) => [deg(r.theta_deg), deg(r.phi_deg), r.reflectance, r.reflectance_stderr, r.lost, r.lost_walls, r.lost_cap, r.lost_numeric, r.mean_bounces, r.photons]);
      s.append(table(['θi', 'φi', 'reflectance', 'std. error', 'lost', 'lost (walls)', 'lost (bounce cap)', 'lost (numeric)', 'mean bounces', 'photons'], rows));
      if (wl.length) {
        const rows2 = [];
        S.incidence.forEach((r) => (r.spectrum || []).forEach((w) => rows2.push([deg(r.theta_deg), deg(r.phi_deg), w.wavelength_um, w.reflectance, w.reflectance_stderr, w.lost])));
        s.append(table(['θi', 'φi', 'λ (µm)', 'reflectance', 'std. error', 'lost'], rows2));
      }
    }

    // Surface.
    {
      const s = section('surface', 'The surface');
      s.append(table(['statistic', 'value'], Object.entries(S.surface).filter(([, v]) => typeof v !== 'object').map(([k, v]) => [k, v])));
      if (D.surface_png) s.append(el('img', { class: 'surface', alt: 'surface.png', src: 'data:image/png;base64,' + D.surface_png }));
    }

    // The picks every map shares.
    const pick = el('div', { class: 'controls', id: 'pick' });
    pick.append(select('pick-theta', 'incidence θi', run.theta_deg.map(deg), redraw));
    pick.append(select('pick-phi', 'light azimuth φi', run.phi_deg.map(deg), redraw));
    pick.append(select('pick-wl', 'wavelength', wl.length ? wl.map((w) => w + ' µm') : ['monochrome'], redraw));
    const picked = () => ({ i: val('pick-theta'), j: val('pick-phi'), l: val('pick-wl') });

    // Hemisphere map.
    const hemi = section('hemisphere', 'The BRDF over the hemisphere (Carlson cells)', 'Radius: θ of the outgoing direction; angle: its azimuth φ. Hover a cell for its value with standard error.');
    hemi.append(pick);
    const hc = el('div', { class: 'controls' });
    hc.append(select('hemi-scale', 'scale', ['log', 'linear'], drawHemisphere));
    hc.append(checkbox('hemi-relerr', 'relative error instead of the BRDF', false, drawHemisphere));
    hc.append(checkbox('hemi-empty', 'mark the cells no photon left through', true, drawHemisphere));
    if (MODELS.length) {
      hc.append(select('hemi-show', 'show', ['table', 'fitted model', '(table − model) / std. error'], drawHemisphere));
      hc.append(select('hemi-model', 'model', MODELS.map((f) => f.overlay.model + ' (' + f.name + ')'), drawHemisphere));
    }
    hemi.append(hc);
    const hemiNote = el('p', { class: 'note', id: 'hemisphere-note' });
    const hover = el('div', { class: 'hover', id: 'hemisphere-hover' });
    hemi.append(hemiNote, hover, plotDiv('hemisphere'));
    // The model picked for the map and its cells at the picked block.
    function hemiModel() {
      if (!MODELS.length) return { f: null, m: null, show: 0 };
      const p = picked();
      const f = MODELS[val('hemi-model')];
      return { f, m: modelAt(f, p.i, p.j, p.l, 'cells', NC), show: val('hemi-show') };
    }
    function cellValues(b) {
      const off = b * NC;
      return { v: D.brdf.slice(off, off + NC), se: D.se.slice(off, off + NC) };
    }
    // The hover text of cell k of the picked block, also kept in the DOM.
    function showHover(k) {
      const p = picked();
      const b = block(p.i, p.j, p.l);
      const { v, se } = cellValues(b);
      const rel = v[k] > 0 ? se[k] / v[k] : NaN;
      hover.dataset.cell = String(k);
      hover.dataset.block = String(b);
      hover.dataset.value = fmt(v[k]);
      hover.dataset.stderr = fmt(se[k]);
      let text = 'θ ' + short(D.cell.theta_deg[k]) + '° [' + short(D.cell.theta_lo_deg[k]) + ', ' + short(D.cell.theta_hi_deg[k]) + '], φ ' +
        short(D.cell.phi_deg[k]) + '°: BRDF ' + fmt(v[k]) + ' ± ' + fmt(se[k]) + ' 1/sr' + (v[k] > 0 ? ', relative error ' + (100 * rel).toFixed(2) + ' %' : ', no photon');
      const { f, m } = hemiModel();
      delete hover.dataset.model;
      delete hover.dataset.residual;
      if (m) {
        hover.dataset.model = fmtModel(m[k]);
        text += '; ' + f.overlay.model + ' model ' + fmtModel(m[k]) + ' 1/sr';
        const res = residuals(v, se, m, summaryAt(p.i, p.j).photons)[k];
        if (Number.isFinite(res)) {
          hover.dataset.residual = res.toFixed(2);
          text += ', (table − model) / std. error ' + res.toFixed(2);
        }
      }
      hover.textContent = text;
    }
    window.roksHover = showHover;
    function drawHemisphere() {
      const p = picked();
      const { v, se } = cellValues(block(p.i, p.j, p.l));
      const relerr = checked('hemi-relerr');
      let values = relerr ? v.map((x, k) => (x > 0 ? se[k] / x : 0)) : v;
      let log = val('hemi-scale') === 0;
      let unit = (log ? 'log10 ' : '') + (relerr ? 'relative error' : 'BRDF (1/sr)');
      const opts = { empty: checked('hemi-empty') };
      const { f, m, show } = hemiModel();
      hemiNote.textContent = '';
      if (show && !m) {
        hemiNote.textContent = f.overlay.model + ' was fitted at ' + where(f) + (NP > 1 ? ' (first light azimuth)' : '') + ', not at the picked incidence and wavelength: the table is shown.';
      } else if (show === 1) {
        values = m;
        unit = (log ? 'log10 ' : '') + f.overlay.model + ' model BRDF (1/sr)';
        hemiNote.textContent = 'The ' + f.overlay.model + ' model fitted to this table (' + f.name + '), its average over each Carlson cell as the fit compares it with the table\'s; hover a cell for both.';
      } else if (show === 2) {
        values = residuals(v, se, m, summaryAt(p.i, p.j).photons);
        const mags = values.filter((x) => Number.isFinite(x)).map(Math.abs).sort((a, b) => a - b);
        opts.range = Math.max(3, mags.length ? mags[Math.floor(0.98 * (mags.length - 1))] : 3);
        opts.diverging = true;
        opts.empty = false;
        log = false;
        unit = '(table − ' + f.overlay.model + ') / std. error';
        hemiNote.textContent = 'Red: the table above the model, blue: below, in standard errors (a cell no photon left through: the error of one photon, as the fit weighs it); the colour scale ends at ±' + short(opts.range) + ' (98 % of the cells within).';
      }
      opts.log = log;
      opts.unit = unit;
      const gd = document.getElementById('plot-hemisphere');
      Plotly.react(gd, hemisphereTraces(cells, values, opts), POLAR_LAYOUT, CONFIG);
      if (!gd.dataset.hooked) {
        gd.on('plotly_hover', (e) => { const pt = e.points[0]; if (pt && pt.customdata !== undefined) showHover(pt.customdata); });
        gd.dataset.hooked = '1';
      }
    }

    // Lobe in 3-D.
    const lobe = section('lobe', 'The BRDF lobe in 3-D', 'Each Carlson cell at its centre direction, at a distance equal to its BRDF (linear) or to log10 of its BRDF over the smallest (log); drag to turn.');
    lobe.append(el('div', { class: 'controls' }, select('lobe-scale', 'distance', ['linear', 'log'], drawLobe)));
    lobe.append(plotDiv('lobe'));
    function drawLobe() {
      const p = picked();
      const { v } = cellValues(block(p.i, p.j, p.l));
      const log = val('lobe-scale') === 1;
      const pos = v.filter((x) => x > 0);
      const floor = pos.length ? Math.min(...pos) : 1;
      const x = [], y = [], z = [], c = [], t = [];
      v.forEach((b, k) => {
        if (!(b > 0)) return;
        const r = log ? Math.log10(b / floor) + 0.05 : b;
        const th = (D.cell.theta_deg[k] * Math.PI) / 180, ph = (D.cell.phi_deg[k] * Math.PI) / 180;
        x.push(r * Math.sin(th) * Math.cos(ph)); y.push(r * Math.sin(th) * Math.sin(ph)); z.push(r * Math.cos(th)); c.push(b);
        t.push('θ ' + short(D.cell.theta_deg[k]) + '°, φ ' + short(D.cell.phi_deg[k]) + '°: ' + fmt(b));
      });
      Plotly.react('plot-lobe', [{ type: 'scatter3d', mode: 'markers', x, y, z, text: t, hoverinfo: 'text',
        marker: { size: 2.5, color: c.map((q) => Math.log10(q)), colorscale: 'Viridis', colorbar: { title: { text: 'log10 BRDF' } } } }],
      { height: 560, margin: { t: 10, b: 10, l: 10, r: 10 }, scene: { aspectmode: 'data', xaxis: { title: { text: 'x' } }, yaxis: { title: { text: 'y' } }, zaxis: { title: { text: 'z (normal)' } } } }, CONFIG);
    }

    // In-plane curves.
    const inp = section('inplane', 'The BRDF in the plane of incidence', 'Pick one or a few incidences (Ctrl-click); the band is ± one standard error. θo is signed: positive on the specular side.' +
      (MODELS.length ? ' Dashed, in its table\'s colour: each model fitted to the table (' + MODELS.map((f, fi) => f.overlay.model + ' ' + ['- -', '···', '-·-', '— —'][fi % 4]).join(', ') + '), averaged over the same in-plane bins.' : ''));
    const nin = D.inplane.brdf.length / (NT * NP * NL);
    const ic = el('div', { class: 'controls' });
    ic.append(select('inplane-theta', 'incidences', run.theta_deg.map(deg), drawInplane, true));
    ic.append(select('inplane-scale', 'scale', ['log', 'linear'], drawInplane));
    inp.append(ic, plotDiv('inplane'));
    document.getElementById('inplane-theta').options[0].selected = true;
    function drawInplane() {
      const p = picked();
      const chosen = [...document.getElementById('inplane-theta').selectedOptions].map((o) => +o.value);
      const traces = [];
      chosen.forEach((i, q) => {
        const off = block(i, p.j, p.l) * nin;
        const th = D.inplane.theta_o.slice(off, off + nin);
        const b = D.inplane.brdf.slice(off, off + nin), se = D.inplane.se.slice(off, off + nin);
        const colour = PALETTE[q % PALETTE.length];
        const lo = b.map((x, k) => Math.max(x - se[k], 0)), hi = b.map((x, k) => x + se[k]);
        traces.push({ x: th, y: lo, mode: 'lines', line: { width: 0 }, hoverinfo: 'skip', showlegend: false });
        traces.push({ x: th, y: hi, mode: 'lines', line: { width: 0 }, fill: 'tonexty', fillcolor: colour + '40', hoverinfo: 'skip', showlegend: false });
        traces.push({ x: th, y: b.map((x) => (x > 0 ? x : null)), mode: 'lines', name: 'θi ' + deg(run.theta_deg[i]), line: { color: colour } });
        MODELS.forEach((f, fi) => {
          const m = modelAt(f, i, p.j, p.l, 'inplane', nin);
          if (m) traces.push({ x: th, y: m, mode: 'lines', name: 'θi ' + deg(run.theta_deg[i]) + ': ' + f.overlay.model + ' model', line: { color: colour, dash: DASHES[fi % DASHES.length], width: 1.5 } });
        });
      });
      const log = val('inplane-scale') === 0;
      Plotly.react('plot-inplane', traces, { height: 440, xaxis: { title: { text: 'θo (deg)' } }, yaxis: { title: { text: 'BRDF (1/sr)' }, type: log ? 'log' : 'linear' }, margin: { t: 20 } }, CONFIG);
    }

    // Reflectance against incidence, by bounces.
    const rb = section('bounces', 'Reflectance against incidence, by bounces', 'Total with ± one standard error, and the part of the light that left after 1, 2, 3, ... reflections.');
    rb.append(plotDiv('bounces'));
    function drawBounces() {
      const p = picked();
      const rows = range(NT).map((i) => summaryAt(i, p.j));
      const kmax = Math.max(...rows.map((r) => r.reflectance_by_bounces.reduce((m, x, k) => (x > 1e-4 ? k : m), 1)));
      const traces = [{ x: run.theta_deg, y: rows.map((r) => r.reflectance), error_y: { type: 'data', array: rows.map((r) => r.reflectance_stderr) }, name: 'all', mode: 'lines+markers', line: { color: '#000' } }];
      for (let k = 1; k <= kmax; k++) traces.push({ x: run.theta_deg, y: rows.map((r) => r.reflectance_by_bounces[k] || 0), name: k + ' bounce' + (k > 1 ? 's' : ''), mode: 'lines+markers', line: { color: PALETTE[(k - 1) % 10] } });
      Plotly.react('plot-bounces', traces, { height: 420, xaxis: { title: { text: 'θi (deg)' } }, yaxis: { title: { text: 'reflectance' } }, margin: { t: 20 } }, CONFIG);
    }

    // Spectral: reflectance against wavelength, colours.
    let drawSpectrum = () => {};
    if (wl.length) {
      const sp = section('spectrum', 'Reflectance against wavelength', 'One curve per incidence (± one standard error); the swatch is the colour of the reflected light under D65 (sRGB), from summary.json' + (D.colour ? ', and the map below the hue of each cell (its colour at full brightness), from colour.csv.' : '.'));
      const sw = el('div', { class: 'controls', id: 'swatches' });
      sp.append(plotDiv('spectrum'), sw);
      if (D.colour) sp.append(plotDiv('colour'));
      drawSpectrum = () => {
        const p = picked();
        const traces = range(NT).map((i) => {
          const r = summaryAt(i, p.j);
          return { x: (r.spectrum || []).map((w) => w.wavelength_um), y: (r.spectrum || []).map((w) => w.reflectance), error_y: { type: 'data', array: (r.spectrum || []).map((w) => w.reflectance_stderr) }, name: 'θi ' + deg(r.theta_deg), mode: 'lines+markers', line: { color: PALETTE[i % 10] } };
        });
        Plotly.react('plot-spectrum', traces, { height: 420, xaxis: { title: { text: 'wavelength (µm)' } }, yaxis: { title: { text: 'reflectance' } }, margin: { t: 20 } }, CONFIG);
        sw.textContent = '';
        range(NT).forEach((i) => {
          const col = summaryAt(i, p.j).colour;
          if (!col) return;
          const rgb = col.srgb_linear.map((x) => Math.round(255 * Math.min(1, Math.max(0, x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055))));
          sw.append(el('span', {}, el('span', { class: 'swatch', style: 'background: rgb(' + rgb.join(',') + ')' }), ' θi ' + deg(run.theta_deg[i])));
        });
        if (D.colour) drawColour();
      };
    }
    function drawColour() {
      const p = picked();
      const cols = D.colour;
      const names = Object.keys(cols);
      // colour.csv's linear sRGB (r, g, b) of each cell, scaled so that its
      // largest channel is 1 (the hue at full brightness), encoded as sRGB.
      const rgbNames = ['r', 'g', 'b'].filter((n) => names.includes(n));
      const off = (p.i * NP + p.j) * NC;
      const enc = (x) => Math.round(255 * Math.min(1, Math.max(0, x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055)));
      const colours = range(NC).map((k) => {
        const rgb = rgbNames.map((n) => cols[n][off + k]);
        const m = Math.max(...rgb);
        return rgb.length === 3 && m > 0 ? 'rgb(' + rgb.map((x) => enc(x / m)).join(',') + ')' : '#fff';
      });
      const c = D.cell;
      Plotly.react('plot-colour', [{ type: 'barpolar', base: c.theta_lo_deg, r: range(NC).map((k) => c.theta_hi_deg[k] - c.theta_lo_deg[k]), theta: range(NC).map((k) => (c.phi_lo_deg[k] + c.phi_hi_deg[k]) / 2), width: range(NC).map((k) => c.phi_hi_deg[k] - c.phi_lo_deg[k]), marker: { color: colours, line: { width: 0 } }, hoverinfo: 'none' }], POLAR_LAYOUT, CONFIG);
    }

    // Polarisation.
    let drawPolar = () => {};
    if (D.polar) {
      const P = D.polar.columns;
      const mueller = D.polar.kind === 'mueller';
      const el4 = mueller ? [0, 1, 2, 3].flatMap((i) => [0, 1, 2, 3].map((j) => 'm' + i + j)) : ['s0', 's1', 's2', 's3'].filter((n) => P[n]);
      const ps = section('polarisation', mueller ? 'The Mueller matrix, m_ij / m00' : 'The Stokes vector', mueller ? 'Each element normalised by m00, with its standard error below, each map on its own colour scale; the degree of polarisation for unpolarised light is sqrt(m10² + m20² + m30²) / m00.' : 'Each element normalised by s0, with the standard errors of s0 ... s3 below, each map on its own colour scale; the degree of polarisation is stokes.csv\'s dop.');
      const g1 = el('div', { class: 'grid4', id: 'polar-values' }), g2 = el('div', { class: 'grid4', id: 'polar-stderr' });
      const first = mueller ? 'm00' : 's0';
      ps.append(el('div', { class: 'controls' }, select('polar-scale', first + ' and its standard error', ['log', 'linear'], () => drawPolar())));
      ps.append(g1, el('h3', { text: 'standard errors' }), g2, el('h3', { text: 'degree of polarisation' }), plotDiv('dop'));
      el4.forEach((n) => { g1.append(plotDiv('polar-' + n, 'cellplot')); g2.append(plotDiv('polar-se-' + n, 'cellplot')); });
      const grid = discGrid(cells, 61);
      drawPolar = () => {
        const p = picked();
        const off = block(p.i, p.j, p.l) * NC;
        const at = (n, k) => P[n][off + k];
        // m00 (s0) and its error on a log scale (log10; empty cells blank)
        // or a linear one; every m_ij / m00 linear, each on its own scale.
        const log = val('polar-scale') === 0;
        const scaled = (f) => (log ? (k) => { const x = f(k); return x > 0 ? Math.log10(x) : null; } : f);
        const lg = log ? 'log10 ' : '';
        el4.forEach((n) => {
          const norm = n === first ? scaled((k) => at(n, k)) : (k) => (at(first, k) > 0 ? at(n, k) / at(first, k) : null);
          Plotly.react('plot-polar-' + n, [discHeatmap(grid, norm, { colorscale: n === first ? 'Viridis' : 'RdBu', zmid: n === first ? undefined : 0 })], discLayout(n === first ? lg + n + ' (1/sr)' : n + '/' + first), { staticPlot: true });
          // Mueller: the errors of m_ij/m00 (mueller.csv has them); Stokes:
          // those of s_i themselves (stokes.csv has no others).
          const ratio = mueller && n !== first;
          const sen = ratio ? n + '_' + first + '_stderr' : n + '_stderr';
          const raw = P[sen] ? (k) => P[sen][off + k] : (k) => null;
          const sev = n === first ? scaled(raw) : raw;
          Plotly.react('plot-polar-se-' + n, [discHeatmap(grid, sev, { colorscale: 'Viridis' })], discLayout((n === first ? lg : '') + 'std. error of ' + (ratio ? n + '/' + first : n + ' (1/sr)')), { staticPlot: true });
        });
        const lin = mueller ? ['m10', 'm20', 'm30'] : ['s1', 's2', 's3'];
        const dop = P.dop
          ? (k) => (at(first, k) > 0 ? at('dop', k) : null)
          : (k) => (at(first, k) > 0 ? Math.hypot(...lin.filter((n) => P[n]).map((n) => at(n, k))) / at(first, k) : null);
        Plotly.react('plot-dop', [discHeatmap(grid, dop, { colorscale: 'Viridis' })], Object.assign(discLayout('degree of polarisation'), { height: 420 }), CONFIG);
      };
    }

    // Realisations and anisotropy.
    const real = S.incidence.some((r) => r.realisations);
    if (real || S.anisotropy) {
      const rs = section('spread', 'Spread over realisations and anisotropy');
      if (real) {
        rs.append(plotDiv('realisations'));
        const traces = S.incidence.filter((r) => r.realisations).map((r, q) => ({ x: r.realisations.reflectance.map((_, k) => k), y: r.realisations.reflectance, error_y: { type: 'data', array: r.realisations.reflectance_stderr }, mode: 'markers', name: 'θi ' + deg(r.theta_deg) + ', φi ' + deg(r.phi_deg), marker: { color: PALETTE[q % 10] } }));
        Plotly.react('plot-realisations', traces, { height: 400, xaxis: { title: { text: 'realisation' }, dtick: 1 }, yaxis: { title: { text: 'reflectance' } }, margin: { t: 20 } }, CONFIG);
        rs.append(table(['θi', 'φi', 'realisations', 'spread', 'std. error of the mean', 'Monte Carlo spread', 'surface spread'], S.incidence.filter((r) => r.realisations).map((r) => [deg(r.theta_deg), deg(r.phi_deg), r.realisations.reflectance.length, r.realisations.spread, r.realisations.spread_stderr_of_mean, r.realisations.monte_carlo_spread, r.realisations.surface_spread])));
      }
      if (S.anisotropy) {
        const a = S.anisotropy;
        rs.append(el('p', { id: 'anisotropy', text: 'Anisotropy: chi²/dof ' + short(a.chi2_dof) + ' over ' + a.dof + ' degrees of freedom (bound ' + short(a.bound) + ', p-value ' + short(a.p_value) + ').' }));
        rs.append(plotDiv('anisotropy'));
        const pairs = a.pairs || [];
        Plotly.react('plot-anisotropy', [
          { type: 'bar', x: pairs.map((q) => 'θi ' + q.theta_i_deg + '°: φ ' + q.phi_a_deg + '° vs ' + q.phi_b_deg + '°'), y: pairs.map((q) => q.chi2_dof), name: 'chi²/dof' },
          { type: 'scatter', mode: 'markers', x: pairs.map((q) => 'θi ' + q.theta_i_deg + '°: φ ' + q.phi_a_deg + '° vs ' + q.phi_b_deg + '°'), y: pairs.map((q) => q.bound), name: 'bound', marker: { symbol: 'line-ew-open', size: 30, color: '#a00' } },
        ], { height: 360, yaxis: { title: { text: 'chi²/dof of the azimuth-shifted tables' } }, margin: { t: 20 } }, CONFIG);
      }
    }

    // Exports and fits.
    {
      const pr = D.products;
      const s = section('products', 'Exports and fits in the folder');
      s.append(el('p', { text: pr.exports.length ? 'Exports: ' + pr.exports.join(', ') + '.' : 'No exports in the folder.' }));
      if (!pr.fits.length) s.append(el('p', { text: 'No fits in the folder (roks fit-model).' }));
      const traces = [];
      pr.fits.forEach((f, q) => {
        const d = f.doc || {};
        s.append(el('p', { class: /NOT OK/.test(d.verdict || '') ? 'bad' : 'ok', text: f.name + ': ' + (d.verdict || (d.advice || 'no verdict')) }));
        if (f.overlay) s.append(el('p', { class: 'note', text: 'The ' + f.overlay.model + ' model is drawn over its table (' + where(f) + ') in the hemisphere map (show: fitted model, or (table − model) / std. error) and, dashed, in the in-plane curves.' }));
        if (f.not_drawn) s.append(el('p', { class: 'bad', text: 'The model of ' + f.name + ' is not drawn over the table: ' + f.not_drawn + '.' }));
        const rows = (d.fits || []).flatMap((fit) => fit.reflectance || []);
        if (rows.length) {
          const colour = PALETTE[q % 10];
          traces.push({ x: rows.map((r) => r.theta_i_deg), y: rows.map((r) => r.table), error_y: { type: 'data', array: rows.map((r) => 4 * r.table_stderr) }, mode: 'markers', name: 'table fitted by ' + (d.model || f.name), marker: { color: colour } });
          traces.push({ x: rows.map((r) => r.theta_i_deg), y: rows.map((r) => r.model), mode: 'lines', name: (d.model || f.name) + ' model', line: { color: colour } });
        }
      });
      if (traces.length) {
        s.append(el('p', { class: 'note', text: 'Each model\'s reflectance drawn over that of the table it was fitted to, in the table\'s colour (error bars: 4 standard errors).' }));
        s.append(plotDiv('fits'));
        Plotly.react('plot-fits', traces, { height: 380, xaxis: { title: { text: 'θi (deg)' } }, yaxis: { title: { text: 'reflectance' } }, margin: { t: 20 } }, CONFIG);
      }
    }

    function redraw() {
      drawHemisphere();
      drawLobe();
      drawInplane();
      drawBounces();
      drawSpectrum();
      drawPolar();
    }
    redraw();
  }

  function traceViews() {
    describe([
      ['scene', S.name], ['scene file', S.scene], ['content sha256', S.content.scene_sha256], ['seed', S.seed],
      ['beam positions', S.sources.length], ['wavelengths (µm)', (S.wavelengths_um || []).length ? S.wavelengths_um.join(', ') : 'monochrome'],
      ['far field', S.farfield ? 'tallied' : 'not tallied'], ['roks version', S.version],
    ]);
    const R = D.reflectance;
    const n = R.reflectance.length;
    const label = range(n).map((k) => '(' + [R.x[k], R.y[k], R.z[k]].map(short).join(', ') + ')' + (R.wavelength_um ? ' ' + R.wavelength_um[k] + ' µm' : ''));
    {
      const spectral = (S.wavelengths_um || []).length > 1;
      const s = section('beam', spectral ? 'Reflectance per beam position and wavelength' : 'Reflectance per beam position',
        spectral ? 'Each wavelength\'s reflectance (summary.json\'s spectrum, ± one standard error): against the wavelength for the beam positions picked (Ctrl-click), or against the beam position, one curve per wavelength.' : '');
      const where = (q) => 'position ' + (q + 1) + ' (' + S.sources[q].position.map(short).join(', ') + ')';
      if (spectral) {
        const np = S.sources.length;
        const c = el('div', { class: 'controls' });
        c.append(select('beam-x', 'against', ['wavelength', 'beam position'], drawBeam));
        c.append(select('beam-positions', 'beam positions', S.sources.map((_, q) => where(q)), drawBeam, true));
        s.append(c);
        // The first, middle and last positions at first.
        [...new Set([0, Math.floor((np - 1) / 2), np - 1])].forEach((q) => { document.getElementById('beam-positions').options[q].selected = true; });
      }
      s.append(plotDiv('beam'));
      function drawBeam() {
        if (spectral && val('beam-x') === 0) {
          const chosen = [...document.getElementById('beam-positions').selectedOptions].map((o) => +o.value);
          const traces = chosen.map((q, c) => {
            const sp = S.sources[q].spectrum || [];
            return { x: sp.map((w) => w.wavelength_um), y: sp.map((w) => w.reflectance), error_y: { type: 'data', array: sp.map((w) => w.reflectance_stderr) }, mode: 'lines+markers', name: where(q), line: { color: PALETTE[c % 10] } };
          });
          Plotly.react('plot-beam', traces, { height: 420, xaxis: { title: { text: 'wavelength (µm)' } }, yaxis: { title: { text: 'reflectance' } }, margin: { t: 20 } }, CONFIG);
          return;
        }
        const series = R.wavelength_um ? [...new Set(R.wavelength_um)] : [null];
        const traces = series.map((w, q) => {
          const ks = range(n).filter((k) => w === null || R.wavelength_um[k] === w);
          return { x: ks.map((k) => '(' + [R.x[k], R.y[k], R.z[k]].map(short).join(', ') + ')'), y: ks.map((k) => R.reflectance[k]), error_y: { type: 'data', array: ks.map((k) => R.reflectance_stderr[k]) }, mode: 'lines+markers', name: w === null ? 'reflectance' : w + ' µm', line: { color: PALETTE[q % 10] } };
        });
        Plotly.react('plot-beam', traces, { height: 420, xaxis: { title: { text: 'beam position (x, y, z)' } }, yaxis: { title: { text: 'reflectance' } }, margin: { t: 20 } }, CONFIG);
      }
      drawBeam();
      s.append(table(['beam position', 'reflectance', 'std. error'], range(n).map((k) => [label[k], R.reflectance[k], R.reflectance_stderr[k]])));
    }
    {
      const s = section('absorbed', 'Absorbed share per wall', 'The share of each beam position\'s light absorbed by each wall, with the reflected and missed shares.');
      s.append(plotDiv('absorbed'));
      const walls = [...new Set(S.sources.flatMap((p) => Object.keys(p.absorbed)))];
      const x = S.sources.map((p) => '(' + p.position.map(short).join(', ') + ')');
      const traces = walls.map((w, q) => ({ type: 'bar', x, y: S.sources.map((p) => p.absorbed[w] || 0), error_y: { type: 'data', array: S.sources.map((p) => (p.absorbed_stderr || {})[w] || 0) }, name: 'absorbed by ' + w, marker: { color: PALETTE[q % 10] } }));
      traces.push({ type: 'bar', x, y: S.sources.map((p) => p.reflectance), name: 'reflected', marker: { color: '#888' } });
      traces.push({ type: 'bar', x, y: S.sources.map((p) => p.missed), name: 'missed', marker: { color: '#ccc' } });
      Plotly.react('plot-absorbed', traces, { barmode: 'stack', height: 420, xaxis: { title: { text: 'beam position (x, y, z)' } }, yaxis: { title: { text: 'share of the beam' } }, margin: { t: 20 } }, CONFIG);
    }
    if (D.farfield) {
      const F = D.farfield;
      const s = section('farfield', 'The far field', 'The BRDF of the object seen from afar, per beam position, over the Carlson cells (log10).');
      const sources = [...new Set(F.source)];
      s.append(el('div', { class: 'controls' }, select('farfield-source', 'beam position', sources.map((q) => String(q) + ' ' + (S.sources[q] ? '(' + S.sources[q].position.map(short).join(', ') + ')' : '')), drawFar)));
      s.append(plotDiv('farfield'));
      function drawFar() {
        const q = sources[val('farfield-source')];
        const ks = range(F.source.length).filter((k) => F.source[k] === q);
        Plotly.react('plot-farfield', hemisphereTraces(new Cells(F.cell), ks.map((k) => F.brdf[k]), { log: true, unit: 'log10 BRDF (1/sr)', empty: false }), POLAR_LAYOUT, CONFIG);
      }
      drawFar();
    }
  }

  document.body.dataset.views = views.join(' ');
  document.body.dataset.ready = '1';
}
