// crosslink comparison report: builds the Vega-Lite charts from the REPORT object written by
// compare/report_html.cpp. Renders with vega-embed (SVG renderer) and writes the outcome into
// #render-status (data-status="ok" | "error"), which the headless-browser test reads.
(function () {
  const statusEl = document.getElementById('render-status');
  const errors = [];
  function setStatus(state, text) {
    statusEl.dataset.status = state;
    statusEl.textContent = text;
  }
  window.addEventListener('error', (e) => {
    errors.push(String(e.message));
    setStatus('error', 'script error: ' + errors.join('; '));
  });
  window.addEventListener('unhandledrejection', (e) => {
    errors.push(String(e.reason));
    setStatus('error', 'script error: ' + errors.join('; '));
  });

  const R = REPORT;
  const driverTitle = R.driver.title || 'driver [' + R.driver.unit + ']';
  const methodOrder = R.methods;
  const palette = ['#222222', '#1f77b4', '#2ca02c', '#d62728', '#9467bd', '#ff7f0e', '#8c564b'];
  const colorScale = {domain: methodOrder, range: palette.slice(0, methodOrder.length)};
  const dashes = methodOrder.map((m, i) => (i === 0 ? [1, 0] : [6 - i, 2 + i]));

  // Long rows of one channel: every method's value, and its signed % of peak.
  function channelRows(name) {
    const ch = R.channels[name];
    const rows = [];
    const flagged = [];
    for (let k = 0; k < R.driver.values.length; k++) {
      const d = R.driver.values[k];
      rows.push({driver: d, method: methodOrder[0], value: ch.ref[k], pct: null});
      if (!R.driver.usable[k]) flagged.push({driver: d, value: ch.ref[k], method: 'flagged'});
      for (const m of Object.keys(ch.methods)) {
        const s = ch.methods[m];
        rows.push({driver: d, method: m, value: s.v[k], pct: s.in[k] ? s.p[k] : null});
      }
    }
    return {rows, flagged};
  }

  function chartSpec(quantity) {
    const axisX = {field: 'driver', type: 'quantitative', title: driverTitle};
    const colour = {field: 'method', type: 'nominal', scale: colorScale, title: 'method'};
    const dash = {field: 'method', type: 'nominal',
                  scale: {domain: methodOrder, range: dashes}, legend: null};
    return {
      $schema: 'https://vega.github.io/schema/vega-lite/v6.json',
      datasets: {series: [], flagged: []},
      // Room for the y axes' labels and titles, which the concatenation otherwise clips.
      padding: {left: 60, top: 5, right: 5, bottom: 5},
      vconcat: [
        {
          width: 640, height: 220,
          layer: [
            {data: {name: 'series'}, mark: {type: 'line', strokeWidth: 1.6, clip: true},
             encoding: {x: axisX, y: {field: 'value', type: 'quantitative',
                                        title: quantity + ' [file units]',
                                        scale: {zero: false}},
                        color: colour, strokeDash: dash,
                        tooltip: [{field: 'method'}, {field: 'driver', format: '.2f'},
                                  {field: 'value', format: '.6g'}]}},
            {data: {name: 'flagged'}, mark: {type: 'point', shape: 'cross', color: '#d62728',
                                             size: 30},
             encoding: {x: axisX, y: {field: 'value', type: 'quantitative'}}},
          ],
        },
        {
          width: 640, height: 130,
          data: {name: 'series'},
          transform: [{filter: 'datum.pct != null'}],
          mark: {type: 'line', strokeWidth: 1.2},
          encoding: {x: axisX,
                     y: {field: 'pct', type: 'quantitative',
                         title: '% of peak (method - exact)'},
                     color: colour,
                     tooltip: [{field: 'method'}, {field: 'driver', format: '.2f'},
                               {field: 'pct', format: '.3g'}]},
        },
      ],
      resolve: {scale: {color: 'shared'}},
    };
  }

  // The mechanism at the drawing's driver value: links, guides, points, instant centres.
  function drawingSpec() {
    const D = R.drawing;
    const xs = [], ys = [];
    for (const p of D.points.concat(D.centres)) { xs.push(p.x); ys.push(p.y); }
    const cx = (Math.min(...xs) + Math.max(...xs)) / 2, cy = (Math.min(...ys) + Math.max(...ys)) / 2;
    let half = Math.max(Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys)) / 2;
    half = half * 1.15 + 1e-9;
    const sx = {domain: [cx - half, cx + half], nice: false, zero: false};
    const sy = {domain: [cy - half, cy + half], nice: false, zero: false};
    const X = {field: 'x', type: 'quantitative', scale: sx, title: 'x [' + D.unit + ']'};
    const Y = {field: 'y', type: 'quantitative', scale: sy, title: 'y [' + D.unit + ']'};
    const X2 = {field: 'x2'}, Y2 = {field: 'y2'};
    return {
      $schema: 'https://vega.github.io/schema/vega-lite/v6.json',
      width: 460, height: 460,
      layer: [
        {data: {values: D.guides}, mark: {type: 'rule', strokeDash: [6, 4], color: '#888'},
         encoding: {x: X, y: Y, x2: X2, y2: Y2}},
        {data: {values: D.segments}, mark: {type: 'rule', strokeWidth: 5, opacity: 0.75},
         encoding: {x: X, y: Y, x2: X2, y2: Y2,
                    color: {field: 'link', type: 'nominal', title: 'link'},
                    tooltip: [{field: 'link'}]}},
        {data: {values: D.points},
         mark: {type: 'point', filled: true, size: 70, color: '#222'},
         encoding: {x: X, y: Y,
                    shape: {field: 'kind', type: 'nominal', title: 'point',
                            scale: {domain: ['ground pivot', 'moving', 'slider block'],
                                    range: ['triangle-up', 'circle', 'square']}},
                    tooltip: [{field: 'name'}, {field: 'x', format: '.4f'},
                              {field: 'y', format: '.4f'}]}},
        {data: {values: D.points}, mark: {type: 'text', dx: 9, dy: -9, fontSize: 13},
         encoding: {x: X, y: Y, text: {field: 'name'}}},
        {data: {values: D.centres},
         mark: {type: 'point', shape: 'diamond', filled: false, size: 90, color: '#d62728'},
         encoding: {x: X, y: Y, tooltip: [{field: 'name'}, {field: 'x', format: '.4f'},
                                          {field: 'y', format: '.4f'}]}},
        {data: {values: D.centres},
         mark: {type: 'text', dx: 10, dy: 10, fontSize: 11, color: '#d62728'},
         encoding: {x: X, y: Y, text: {field: 'name'}}},
        // Joint reactions: first link on second, at the joint (exact kinetostatics).
        {data: {values: D.forces}, mark: {type: 'rule', strokeWidth: 2, color: '#2ca02c'},
         encoding: {x: X, y: Y, x2: X2, y2: Y2, tooltip: [{field: 'label'}]}},
        {data: {values: D.forces},
         mark: {type: 'point', shape: 'triangle-up', filled: true, size: 60, color: '#2ca02c'},
         encoding: {x: {field: 'x2', type: 'quantitative', scale: sx},
                    y: {field: 'y2', type: 'quantitative', scale: sy},
                    angle: {field: 'angle', type: 'quantitative', scale: null},
                    tooltip: [{field: 'label'}]}},
        {data: {values: D.forces},
         mark: {type: 'text', dx: 6, dy: 12, fontSize: 10, color: '#2ca02c'},
         encoding: {x: {field: 'x2', type: 'quantitative', scale: sx},
                    y: {field: 'y2', type: 'quantitative', scale: sy},
                    text: {field: 'label'}}},
      ],
      title: D.effort ? {text: 'reactions (green): first link on second; ' + D.effort,
                         fontSize: 11, fontWeight: 'normal', anchor: 'start'} : undefined,
    };
  }

  const opts = {renderer: 'svg', actions: false};
  const jobs = [];
  jobs.push(vegaEmbed('#drawing', drawingSpec(), opts));

  // One chart per quantity class, with a channel selector (worst channel first).
  for (const q of R.quantities) {
    const box = document.getElementById('chart-' + q.name);
    const select = document.getElementById('select-' + q.name);
    for (const c of q.channels) {
      const o = document.createElement('option');
      o.value = c.name;
      o.textContent = c.label;
      select.appendChild(o);
    }
    const job = vegaEmbed(box, chartSpec(q.name), opts).then((result) => {
      const show = (name) => {
        const {rows, flagged} = channelRows(name);
        result.view.change('series', vega.changeset().remove(() => true).insert(rows));
        result.view.change('flagged', vega.changeset().remove(() => true).insert(flagged));
        return result.view.runAsync();
      };
      select.addEventListener('change', () => show(select.value));
      return show(q.channels[0].name).then(() => result);
    });
    jobs.push(job);
  }

  Promise.all(jobs).then((results) => {
    let drawn = 0;
    for (const r of results) {
      const svg = r.view.container().querySelector('svg');
      if (svg && svg.querySelectorAll('path, line, text').length > 0) drawn++;
    }
    if (errors.length) return;
    if (drawn === results.length) setStatus('ok', 'rendered ' + drawn + ' of ' + results.length + ' charts');
    else setStatus('error', 'rendered ' + drawn + ' of ' + results.length + ' charts');
  }).catch((e) => {
    errors.push(String(e));
    setStatus('error', 'chart error: ' + errors.join('; '));
  });
})();
