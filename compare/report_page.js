// crosslink comparison report: builds the Vega-Lite charts from the REPORT object written by
// compare/report_html.cpp. Renders with vega-embed (SVG renderer) and writes the outcome into
// #render-status (data-status="ok" | "error"), which the headless-browser test reads.
(function () {
  const statusEl = document.getElementById('render-status');
  const errors = [];
  // The status is for the headless-browser test (and a reader whose charts failed): hidden when
  // every chart rendered.
  function setStatus(state, text) {
    statusEl.dataset.status = state;
    statusEl.textContent = text;
    statusEl.hidden = state === 'ok';
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
  // One colour and dash per method in every report (the sweep report uses the same colours).
  const methodStyle = {
    analytic: {colour: '#222222', dash: [1, 0]},
    dyads: {colour: '#2ca02c', dash: [8, 3]},
    ic: {colour: '#9467bd', dash: [2, 2]},
    mujoco: {colour: '#1f77b4', dash: [6, 2]},
    bullet: {colour: '#d62728', dash: [4, 2, 1, 2]},
  };
  const style = (m) => methodStyle[m] || {colour: '#8c564b', dash: [1, 1]};
  const colorScale = {domain: methodOrder, range: methodOrder.map((m) => style(m).colour)};
  const dashScale = {domain: methodOrder, range: methodOrder.map((m) => style(m).dash)};

  // Long rows of one channel: every method's value (null where the sample has none: a gap), and
  // its signed % of peak. The samples kept out of a verdict are marked by where they are, not by
  // a value: a band over each, from midway to its neighbours, saying which method and why.
  function channelRows(name) {
    const ch = R.channels[name];
    const x = R.driver.values;
    const rows = [];
    const flagged = [];
    for (let k = 0; k < x.length; k++) {
      const d = x[k];
      rows.push({driver: d, method: methodOrder[0], value: ch.ref[k], pct: null});
      const why = [];
      for (const m of Object.keys(ch.methods)) {
        const s = ch.methods[m];
        rows.push({driver: d, method: m, value: s.v[k], pct: s.in[k] ? s.p[k] : null});
        if (s.out[k] !== null) why.push(m + ': ' + s.out[k]);
      }
      if (!R.driver.usable[k] && why.length === 0) why.push('reference flagged');
      if (why.length) {
        const lo = k > 0 ? (x[k - 1] + d) / 2 : d, hi = k + 1 < x.length ? (x[k + 1] + d) / 2 : d;
        flagged.push({driver: Math.min(lo, hi), driver2: Math.max(lo, hi),
                      reason: 'kept out of the verdict: ' + why.join('; ')});
      }
    }
    return {rows, flagged};
  }

  // A channel's chart: its values by method over the driver (gaps where a sample has no value,
  // flagged samples shaded), and below it each method's difference from the exact values.
  function chartSpec(name) {
    const unit = R.channels[name].unit;
    const axisX = {field: 'driver', type: 'quantitative', title: driverTitle};
    // Colour and dash share the field and title, so one legend shows both.
    const colour = {field: 'method', type: 'nominal', scale: colorScale, title: 'method'};
    const dash = {field: 'method', type: 'nominal', scale: dashScale, title: 'method'};
    const flaggedRule = {data: {name: 'flagged'},
                         mark: {type: 'rect', color: '#d62728', opacity: 0.15},
                         encoding: {x: axisX, x2: {field: 'driver2'},
                                    tooltip: [{field: 'reason'}]}};
    const cursor = {data: {name: 'cursor'},
                    mark: {type: 'rule', color: '#555', strokeDash: [2, 2]},
                    encoding: {x: axisX}};
    // Break the line at a null instead of joining its neighbours across the gap.
    const gaps = 'break-paths-filter-domains';
    return {
      $schema: 'https://vega.github.io/schema/vega-lite/v6.json',
      datasets: {series: [], flagged: [], cursor: []},
      // Room for the y axes' labels and titles, which the concatenation otherwise clips.
      padding: {left: 70, top: 5, right: 5, bottom: 5},
      vconcat: [
        {
          width: 640, height: 220,
          layer: [
            flaggedRule, cursor,
            {data: {name: 'series'},
             mark: {type: 'line', strokeWidth: 1.6, clip: true, invalid: gaps},
             encoding: {x: axisX, y: {field: 'value', type: 'quantitative',
                                        title: name + ' [' + unit + ']', scale: {zero: false}},
                        color: colour, strokeDash: dash,
                        tooltip: [{field: 'method'}, {field: 'driver', format: '.2f'},
                                  {field: 'value', format: '.6g'}]}},
          ],
        },
        {
          width: 640, height: 130,
          layer: [
            flaggedRule, cursor,
            {data: {name: 'series'},
             transform: [{filter: 'datum.method != ' + JSON.stringify(methodOrder[0])}],
             mark: {type: 'line', strokeWidth: 1.2, clip: true, invalid: gaps},
             encoding: {x: axisX,
                        y: {field: 'pct', type: 'quantitative', title: 'difference [% of peak]'},
                        color: colour, strokeDash: dash,
                        tooltip: [{field: 'method'}, {field: 'driver', format: '.2f'},
                                  {field: 'pct', format: '.3g'}]}},
          ],
        },
      ],
      resolve: {scale: {color: 'shared', strokeDash: 'shared'}},
    };
  }

  // The mechanism at sample k: links and points from the reference's channels; the guides of
  // the ground always; instant centres, reactions and slots on moving links only at the pose the
  // report was drawn at (sample k0), where they were computed.
  const D = R.drawing;
  const at = (name, k) => (R.channels[name] ? R.channels[name].ref[k] : null);
  let k0 = 0;
  if (!R.driver.title) {
    for (let k = 0; k < R.driver.values.length; k++)
      if (Math.abs(R.driver.values[k] - D.at) < Math.abs(R.driver.values[k0] - D.at)) k0 = k;
  }
  // Coincident centres share one label ("I1,2 = I3,4"), so labels do not overprint.
  function centreLabels() {
    const groups = new Map();
    for (const c of D.centres) {
      const key = c.x.toPrecision(6) + ',' + c.y.toPrecision(6);
      if (!groups.has(key)) groups.set(key, {x: c.x, y: c.y, names: []});
      groups.get(key).names.push(c.name);
    }
    return [...groups.values()].map((g) => ({x: g.x, y: g.y, name: g.names.join(' = ')}));
  }
  // Paths of the moving points over the sweep (coupler curves), broken where a sample has none.
  function paths() {
    const rows = [];
    for (const p of D.points) {
      if (p.kind === 'ground pivot') continue;
      for (let k = 0; k < R.driver.values.length; k++)
        rows.push({name: p.name, k, x: at('x.' + p.name, k), y: at('y.' + p.name, k)});
    }
    return rows;
  }
  function poseAt(k) {
    const here = k === k0;
    const segments = D.segments.map((s) => ({
      link: s.link, x: at('x.' + s.p, k), y: at('y.' + s.p, k),
      x2: at('x.' + s.q, k), y2: at('y.' + s.q, k),
    })).filter((s) => s.x !== null && s.y !== null && s.x2 !== null && s.y2 !== null);
    const points = D.points.map((p) => ({
      name: p.name, kind: p.kind,
      x: p.kind === 'ground pivot' ? p.x : at('x.' + p.name, k),
      y: p.kind === 'ground pivot' ? p.y : at('y.' + p.name, k),
    })).filter((p) => p.x !== null && p.y !== null);
    return {
      segments, points,
      guides: D.guides.filter((g) => here || !g.moving),
      centres: here ? D.centres : [], centreLabels: here ? centreLabels() : [],
      forces: here ? D.forces : [],
    };
  }

  function drawingSpec() {
    const xs = [], ys = [];
    for (const p of D.points.concat(D.centres)) { xs.push(p.x); ys.push(p.y); }
    for (const r of paths()) if (r.x !== null && r.y !== null) { xs.push(r.x); ys.push(r.y); }
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
      datasets: {segments: [], points: [], guides: [], centres: [], centreLabels: [], forces: []},
      layer: [
        {data: {values: paths()},
         mark: {type: 'line', strokeWidth: 1, color: '#bbb', clip: true,
                invalid: 'break-paths-filter-domains'},
         encoding: {x: X, y: Y, detail: {field: 'name'}, order: {field: 'k'}}},
        {data: {name: 'guides'},
         mark: {type: 'rule', strokeDash: [6, 4], color: '#888', clip: true},
         encoding: {x: X, y: Y, x2: X2, y2: Y2}},
        {data: {name: 'segments'}, mark: {type: 'rule', strokeWidth: 5, opacity: 0.75, clip: true},
         encoding: {x: X, y: Y, x2: X2, y2: Y2,
                    color: {field: 'link', type: 'nominal', title: 'link'},
                    tooltip: [{field: 'link'}]}},
        // Centres under the points, small and hollow, so that a centre at a pivot leaves it seen.
        {data: {name: 'centres'},
         mark: {type: 'point', shape: 'diamond', filled: false, size: 50, color: '#d62728',
                clip: true},
         encoding: {x: X, y: Y, tooltip: [{field: 'name'}, {field: 'x', format: '.4f'},
                                          {field: 'y', format: '.4f'}]}},
        {data: {name: 'centreLabels'},
         mark: {type: 'text', dx: 10, dy: 12, fontSize: 10, color: '#d62728', align: 'left',
                clip: true},
         encoding: {x: X, y: Y, text: {field: 'name'}}},
        {data: {name: 'points'},
         mark: {type: 'point', filled: true, size: 70, color: '#222'},
         encoding: {x: X, y: Y,
                    shape: {field: 'kind', type: 'nominal', title: 'point',
                            scale: {domain: ['ground pivot', 'moving', 'slider block'],
                                    range: ['triangle-up', 'circle', 'square']}},
                    tooltip: [{field: 'name'}, {field: 'x', format: '.4f'},
                              {field: 'y', format: '.4f'}]}},
        {data: {name: 'points'}, mark: {type: 'text', dx: 9, dy: -9, fontSize: 13},
         encoding: {x: X, y: Y, text: {field: 'name'}}},
        // Joint reactions: first link on second, at the joint (exact kinetostatics).
        {data: {name: 'forces'}, mark: {type: 'rule', strokeWidth: 2, color: '#2ca02c'},
         encoding: {x: X, y: Y, x2: X2, y2: Y2, tooltip: [{field: 'label'}]}},
        {data: {name: 'forces'},
         mark: {type: 'point', shape: 'triangle-up', filled: true, size: 60, color: '#2ca02c'},
         encoding: {x: {field: 'x2', type: 'quantitative', scale: sx},
                    y: {field: 'y2', type: 'quantitative', scale: sy},
                    angle: {field: 'angle', type: 'quantitative', scale: null},
                    tooltip: [{field: 'label'}]}},
        {data: {name: 'forces'},
         mark: {type: 'text', dx: 6, dy: 12, fontSize: 10, color: '#2ca02c'},
         encoding: {x: {field: 'x2', type: 'quantitative', scale: sx},
                    y: {field: 'y2', type: 'quantitative', scale: sy},
                    text: {field: 'label'}}},
      ],
      title: D.effort ? {text: 'reactions (green): first link on second; ' + D.effort,
                         fontSize: 11, fontWeight: 'normal', anchor: 'start'} : undefined,
    };
  }

  function replace(view, name, rows) {
    view.change(name, vega.changeset().remove(() => true).insert(rows));
  }

  const opts = {renderer: 'svg', actions: false};
  const jobs = [];
  const charts = [];  // the views of the channel charts, for the cursor
  let sample = k0;
  const cursorRows = () => [{driver: R.driver.values[sample]}];

  const drawingJob = vegaEmbed('#drawing', drawingSpec(), opts).then((result) => {
    const slider = document.getElementById('sample');
    const label = document.getElementById('sample-value');
    const show = () => {
      const pose = poseAt(sample);
      for (const name of Object.keys(pose)) replace(result.view, name, pose[name]);
      label.textContent = driverTitle.replace(/ \[.*\]$/, '') + ' = ' +
                          R.driver.values[sample] + ' ' + R.driver.unit +
                          (R.driver.usable[sample] ? '' : ' (flagged)');
      for (const v of charts) {
        replace(v, 'cursor', cursorRows());
        v.runAsync();
      }
      return result.view.runAsync();
    };
    if (slider) {
      slider.value = String(k0);
      slider.addEventListener('input', () => {
        sample = Number(slider.value);
        show();
      });
    }
    return show().then(() => result);
  });
  jobs.push(drawingJob);

  // One chart per quantity class, with a channel selector (worst channel first); a new channel
  // redraws the chart, so that its axis names the channel and its unit.
  for (const q of R.quantities) {
    const box = document.getElementById('chart-' + q.name);
    const select = document.getElementById('select-' + q.name);
    for (const c of q.channels) {
      const o = document.createElement('option');
      o.value = c.name;
      o.textContent = c.label;
      select.appendChild(o);
    }
    let current = null;
    const show = (name) => vegaEmbed(box, chartSpec(name), opts).then((result) => {
      const {rows, flagged} = channelRows(name);
      replace(result.view, 'series', rows);
      replace(result.view, 'flagged', flagged);
      replace(result.view, 'cursor', cursorRows());
      if (current) charts.splice(charts.indexOf(current), 1, result.view);
      else charts.push(result.view);
      current = result.view;
      return result.view.runAsync().then(() => result);
    });
    select.addEventListener('change', () => show(select.value));
    jobs.push(show(q.channels[0].name));
  }

  // What the browser test checks beyond rendering: every chart has a legend, and no flagged
  // sample carries a value that does not exist there (a rate or force of the reference; anything
  // of another method), so that none can be drawn.
  function flaggedValues() {
    let n = 0;
    for (const q of R.quantities) {
      const positional = q.name === 'position' || q.name === 'angle';
      for (const c of q.channels) {
        const ch = R.channels[c.name];
        for (let k = 0; k < R.driver.values.length; k++) {
          if (R.driver.usable[k]) continue;
          if (!positional && ch.ref[k] !== null) n++;
          for (const m of Object.keys(ch.methods)) if (ch.methods[m].v[k] !== null) n++;
        }
      }
    }
    return n;
  }

  Promise.all(jobs).then((results) => {
    let drawn = 0, legends = 0;
    for (const r of results) {
      const svg = r.view.container().querySelector('svg');
      if (svg && svg.querySelectorAll('path, line, text').length > 0) drawn++;
      if (svg && svg.querySelector('.role-legend')) legends++;
    }
    if (errors.length) return;
    const flagged = flaggedValues();
    statusEl.dataset.legends = String(legends);
    statusEl.dataset.flaggedValues = String(flagged);
    const text = 'rendered ' + drawn + ' of ' + results.length + ' charts, ' + legends +
                 ' with a legend; ' + flagged + ' values at flagged samples';
    setStatus(drawn === results.length && legends === results.length && flagged === 0
                  ? 'ok' : 'error', text);
  }).catch((e) => {
    errors.push(String(e));
    setStatus('error', 'chart error: ' + errors.join('; '));
  });
})();
