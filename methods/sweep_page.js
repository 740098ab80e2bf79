// crosslink settings-sweep report: Vega-Lite charts of error against cost and against dt, built
// from the REPORT object written by methods/sweep_report.cpp. Writes the outcome into
// #render-status (data-status="ok" | "error") like the comparison report. A page of several
// definitions runs it once per definition, REPORT.prefix naming that section's elements.
(function () {
  const P = '#' + (REPORT.prefix || '');
  const statusEl = document.querySelector(P + 'render-status');
  const errors = [];
  function setStatus(state, text) {  // for the browser test; hidden once the charts render
    statusEl.dataset.status = state;
    statusEl.textContent = text;
    statusEl.hidden = state === 'ok';
  }
  window.addEventListener('error', (e) => {
    errors.push(String(e.message));
    setStatus('error', 'script error: ' + errors.join('; '));
  });

  const R = REPORT;
  const schema = 'https://vega.github.io/schema/vega-lite/v6.json';
  // Every engine's colour and dash from the engine table (R.styles, methods::method_styles): an
  // engine outside a fixed domain was drawn with no point and no legend entry (Simbody).
  const styled = Object.keys(R.styles);
  const engineColour = {domain: styled, range: styled.map((m) => R.styles[m].colour)};
  const engineDash = (engine) => {
    const s = R.styles[engine];
    return s && s.dash.length ? s.dash : [1, 0];
  };
  // An engine of the sweep without a style would be drawn with no point: an error of the page.
  for (const r of R.rows)
    if (!R.styles[r.engine]) throw new Error('engine ' + r.engine + ' has no style');
  // Twenty colours that stay apart (Tableau 20, dark and light of ten hues interleaved).
  const seriesPalette = ['#4e79a7', '#f28e2b', '#e15759', '#76b7b2', '#59a14f', '#edc948',
                         '#b07aa1', '#ff9da7', '#9c755f', '#bab0ac', '#a0cbe8', '#ffbe7d',
                         '#ff9d9a', '#86bcb6', '#8cd17d', '#f1ce63', '#d4a6c8', '#fabfd2',
                         '#d7b5a6', '#79706e'];
  const statusShape = {domain: ['ok', 'flagged', 'diverged'],
                       range: ['circle', 'triangle-up', 'cross']};

  // Rows of one class: x, y and what the point means (atEnd: a dynamics case's error at the end
  // of the run instead of the worst over it).
  function rows(cls, atEnd) {
    return R.rows.map((r) => ({
      engine: r.engine, variant: r.variant, series: r.series, setting: r.setting,
      dt: r.dt, cost: r.cost, work: r.work, status: r.status, gap: r.gap,
      error: atEnd ? r.end[cls] : r.err[cls], y: atEnd ? r.yend[cls] : r.y[cls],
      drawn: atEnd ? 'error at the end of the run' : r.drawn[cls], pareto: r.pareto[cls],
    })).filter((r) => r.cost !== null && r.y !== null);  // y null: a run that reads no forces
  }

  const tooltip = [
    {field: 'engine'}, {field: 'setting'}, {field: 'status'},
    {field: 'cost', title: 'wall s per cycle', format: '.3g'},
    {field: 'error', title: 'max % of peak', format: '.3g'},
    {field: 'gap', title: 'max loop gap [m]', format: '.3g'}, {field: 'drawn'},
  ];
  const yScale = {type: 'log', domain: [R.floor, R.ceiling]};

  function costSpec(cls, atEnd) {
    const data = rows(cls, atEnd);
    const engines = data.filter((r) => r.engine !== 'analytic');
    // The front is of error against work (the same in every run); joined in order of work.
    const front = engines.filter((r) => r.pareto).sort((a, b) => a.work - b.work);
    const series = engines.filter((r) => r.status === 'ok')
                          .sort((a, b) => (a.series < b.series ? -1 : a.series > b.series ? 1
                                                                     : b.dt - a.dt));
    const analytic = data.filter((r) => r.engine === 'analytic');
    const X = {field: 'cost', type: 'quantitative', scale: {type: 'log'},
               title: R.costTitle || 'wall time per simulated cycle [s]'};
    const Y = {field: 'y', type: 'quantitative', scale: yScale,
               title: (atEnd ? '% of peak at the end (' : 'max % of peak (') + cls + ')'};
    return {
      $schema: schema, width: 680, height: 380,
      layer: [
        {data: {values: series}, mark: {type: 'line', strokeWidth: 0.8, opacity: 0.35},
         encoding: {x: X, y: Y, detail: {field: 'series'}, order: {field: 'dt', sort: 'descending'},
                    color: {field: 'engine', type: 'nominal', scale: engineColour}}},
        {data: {values: front}, mark: {type: 'line', color: '#000', strokeWidth: 2.2},
         encoding: {x: X, y: Y, order: {field: 'work'}}},
        {data: {values: engines},
         mark: {type: 'point', size: 55, strokeWidth: 1.6},
         encoding: {x: X, y: Y,
                    color: {field: 'engine', type: 'nominal', scale: engineColour,
                            title: 'engine'},
                    shape: {field: 'status', type: 'nominal', scale: statusShape,
                            title: 'status'},
                    fill: {condition: {test: 'datum.pareto', field: 'engine', type: 'nominal',
                                       scale: engineColour},
                           value: 'transparent'},
                    tooltip}},
        {data: {values: analytic},
         mark: {type: 'point', shape: 'diamond', size: 110, filled: true, color: '#777'},
         encoding: {x: X, y: Y, tooltip}},
        {data: {values: analytic}, mark: {type: 'text', dx: 8, dy: -8, align: 'left'},
         encoding: {x: X, y: Y, text: {field: 'variant'}}},
      ],
    };
  }

  function dtSpec(cls) {
    const data = rows(cls).filter((r) => r.engine !== 'analytic');
    const X = {field: 'dt', type: 'quantitative', scale: {type: 'log'}, title: 'time step dt [s]'};
    const Y = {field: 'y', type: 'quantitative', scale: yScale,
               title: 'max % of peak (' + cls + ')'};
    // One colour per series (a sweep has up to about 15), and the engine's dash on top, so no
    // two series share a line style.
    const series = [...new Set(data.map((r) => r.series))];
    const colour = {field: 'series', type: 'nominal', title: 'engine and variant',
                    scale: {domain: series, range: series.map((s, i) => seriesPalette[i % 20])},
                    legend: {labelLimit: 360}};
    const dash = {field: 'series', type: 'nominal', title: 'engine and variant',
                  scale: {domain: series,
                          range: series.map((s) => engineDash(s.split(' ')[0]))},
                  legend: {labelLimit: 360}};
    return {
      $schema: schema, width: 560, height: 320,
      layer: [
        {data: {values: data.filter((r) => r.status === 'ok')},
         mark: {type: 'line', strokeWidth: 1.2},
         encoding: {x: X, y: Y, color: colour, strokeDash: dash, order: {field: 'dt'}}},
        {data: {values: data}, mark: {type: 'point', size: 45, filled: true},
         encoding: {x: X, y: Y, color: colour,
                    shape: {field: 'status', type: 'nominal', scale: statusShape,
                            title: 'status'},
                    tooltip}},
      ],
    };
  }

  const opts = {renderer: 'svg', actions: false};
  const jobs = [];
  for (const cls of R.classes) {
    jobs.push(vegaEmbed(P + 'cost-' + cls, costSpec(cls, false), opts));
    if (R.dynamics) jobs.push(vegaEmbed(P + 'end-' + cls, costSpec(cls, true), opts));
    jobs.push(vegaEmbed(P + 'dt-' + cls, dtSpec(cls), opts));
  }
  Promise.all(jobs).then((results) => {
    let drawn = 0;
    for (const r of results) {
      const svg = r.view.container().querySelector('svg');
      if (svg && svg.querySelectorAll('path, line, text').length > 0) drawn++;
    }
    if (errors.length) return;
    setStatus(drawn === results.length ? 'ok' : 'error',
              'rendered ' + drawn + ' of ' + results.length + ' charts');
  }).catch((e) => {
    errors.push(String(e));
    setStatus('error', 'chart error: ' + errors.join('; '));
  });
})();
