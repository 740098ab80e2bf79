// The layout rules of the comparison report (docs/report.md), measured in the rendered page by
// the browser test (browser_test.cmake appends this script to a copy of the report). Once the
// page's own status says the charts rendered, it measures the drawn SVG with
// getBoundingClientRect and writes one JSON object into <pre id="layout-check">, which the test
// reads from --dump-dom. It uses nothing of the page's layout code: only the SVG Vega drew, the
// REPORT data object and the HTML tables.
(function () {
  const out = document.createElement('pre');
  out.id = 'layout-check';
  document.body.appendChild(out);
  const box = (e) => e.getBoundingClientRect();
  const union = (rects) => rects.reduce((u, r) => ({
    left: Math.min(u.left, r.left), right: Math.max(u.right, r.right),
    top: Math.min(u.top, r.top), bottom: Math.max(u.bottom, r.bottom),
  }), {left: Infinity, right: -Infinity, top: Infinity, bottom: -Infinity});
  // The visible elements of the marks Vega drew for a layer named `name` (class "<name>_marks").
  const marks = (root, name) => [...root.querySelectorAll('g.' + name + '_marks > *')]
      .filter((e) => { const r = box(e); return r.width > 0 || r.height > 0; });

  // The drawing's text labels and the pairs of them that overlap (by more than 0.5 px both ways).
  function labelOverlaps(drawing) {
    const labels = [...drawing.querySelectorAll('g.mark-text.role-mark text')]
        .filter((t) => t.textContent !== '');
    const boxes = labels.map((t) => ({text: t.textContent, r: box(t)}));
    const overlaps = [];
    for (let i = 0; i < boxes.length; i++)
      for (let j = i + 1; j < boxes.length; j++) {
        const a = boxes[i].r, b = boxes[j].r;
        const w = Math.min(a.right, b.right) - Math.max(a.left, b.left);
        const h = Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top);
        if (w > 0.5 && h > 0.5) overlaps.push(boxes[i].text + ' / ' + boxes[j].text);
      }
    return {boxes, overlaps};
  }

  function measure(status) {
    const result = {status};
    const drawing = document.querySelector('#drawing svg');
    // The plot area: the root group's background (width x height of the unit spec).
    const frame = box(drawing.querySelector('g.role-frame.root path.background') ||
                      drawing.querySelector('path.background'));
    result.frame = {width: frame.width, height: frame.height};

    // Labels: every text mark of the drawing (axis, legend and title texts have other roles).
    const {boxes, overlaps} = labelOverlaps(drawing);
    result.labels = boxes.length;
    result.label_overlaps = overlaps;
    // Every point of the drawing is named on it.
    const texts = new Set(boxes.map((b) => b.text));
    result.points_unlabelled = REPORT.drawing.points.map((p) => p.name)
        .filter((n) => !texts.has(n));

    // The linkage's drawn extent (links, points and the paths of the points over the sweep)
    // against the frame, in each direction.
    const linkage = union(['links', 'points', 'paths'].flatMap((n) => marks(drawing, n)).map(box));
    result.fill = {x: (linkage.right - linkage.left) / frame.width,
                   y: (linkage.bottom - linkage.top) / frame.height};

    // Centres: every one of the data is drawn, as a marker or as an arrow, inside the frame.
    const inside = (r) => r.left >= frame.left - 0.5 && r.right <= frame.right + 0.5 &&
                          r.top >= frame.top - 0.5 && r.bottom <= frame.bottom + 0.5;
    const centreMarks = marks(drawing, 'centres'), arrows = marks(drawing, 'centre_arrows');
    const heads = marks(drawing, 'centre_arrow_heads');
    const coincident = new Set(REPORT.drawing.centres.map((c) => c.x.toPrecision(6) + ',' +
                                                               c.y.toPrecision(6)));
    result.centres = {data: coincident.size, markers: centreMarks.length, arrows: arrows.length,
                      outside: centreMarks.concat(arrows, heads).filter((e) => !inside(box(e)))
                          .length};

    // Cams: each profile drawn inside the frame, its pressure angle's two rules and its label.
    const cams = REPORT.drawing.cams || [];
    if (cams.length) {
      const profiles = marks(drawing, 'cam_profiles');
      result.cams = {data: cams.length, profiles: profiles.length,
                     rules: marks(drawing, 'cam_rules').length,
                     labelled: boxes.filter((b) => b.text.startsWith('\u03c6 ')).length,
                     outside: profiles.filter((e) => !inside(box(e))).length};
    }

    // Charts: the x axis spans the sweep, so the exact position channel's line (which has a value
    // at every sample) runs from the plot's left edge to its right edge.
    const chart = document.querySelector('.chart[id^="chart-position"] svg');
    if (chart) {
      // The value panel: the first plot area drawn (the % panel is below it).
      const plot = [...chart.querySelectorAll('path.background')].map(box)
          .filter((r) => r.width > 0 && r.height > 0)[0];
      const lines = [...chart.querySelectorAll('g.mark-line.role-mark path')].map(box)
          .filter((r) => r.width > 0 && (r.top + r.bottom) / 2 >= plot.top &&
                         (r.top + r.bottom) / 2 <= plot.bottom);
      const span = union(lines);
      result.chart = {plot_left: plot.left, plot_right: plot.right, line_left: span.left,
                      line_right: span.right, lines: lines.length};
    }

    // The verdict table: groups by kind of channel, each with a summary line, the worst rows
    // shown and the rest folded in a closed <details>.
    const groups = [...document.querySelectorAll('section.verdict-group')];
    result.verdicts = groups.map((g) => ({
      group: g.dataset.group,
      summary: !!g.querySelector('h3'),
      shown: [...g.querySelectorAll('table tr')].filter((r) => !r.closest('details') &&
                                                               r.querySelector('td')).length,
      folded: [...g.querySelectorAll('details:not([open]) tr')].filter((r) => r.querySelector('td'))
          .length,
      failing: g.querySelectorAll('tr.fail').length,
    }));
    result.verdict_rows_outside_groups = [...document.querySelectorAll('table.verdicts tr')]
        .filter((r) => !r.closest('section.verdict-group')).length;
    result.failures = rules(result);
    return result;
  }

  // The rules (docs/report.md): each broken one is a line of the test's failure.
  function rules(m) {
    const f = [];
    if (m.status !== 'ok') f.push('the page did not render: ' + m.status);
    if (m.label_overlaps.length)
      f.push(m.label_overlaps.length + ' pairs of labels overlap: ' + m.label_overlaps.join(', '));
    if (m.points_unlabelled.length) f.push('points not named: ' + m.points_unlabelled.join(', '));
    if (!Number.isFinite(m.fill.x) || !Number.isFinite(m.fill.y))
      f.push('no linkage drawn in layers named links, points and paths');
    else if (Math.max(m.fill.x, m.fill.y) < 0.8)
      f.push('the linkage fills ' + (100 * m.fill.x).toFixed(1) + ' % of the frame across and ' +
             (100 * m.fill.y).toFixed(1) + ' % down (at least 80 % one way)');
    if (m.centres.outside) f.push(m.centres.outside + ' centre marks or arrows outside the frame');
    if (m.centres.markers + m.centres.arrows !== m.centres.data)
      f.push(m.centres.data + ' centres, ' + m.centres.markers + ' drawn and ' + m.centres.arrows +
             ' arrows');
    if (m.cams) {
      const c = m.cams;
      if (c.profiles !== c.data) f.push(c.data + ' cams, ' + c.profiles + ' profiles drawn');
      if (c.outside) f.push(c.outside + ' cam profiles outside the frame');
      if (c.rules < 2 * c.data) f.push(c.rules + ' pressure-angle rules for ' + c.data + ' cams');
      if (c.labelled !== c.data) f.push(c.labelled + ' pressure angles named for ' + c.data + ' cams');
    }
    if (!m.chart) {
      f.push('no position chart');
    } else if (Math.abs(m.chart.line_left - m.chart.plot_left) > 1.5 ||
               Math.abs(m.chart.line_right - m.chart.plot_right) > 1.5) {
      f.push('the position chart spans ' + m.chart.plot_left.toFixed(1) + '..' +
             m.chart.plot_right.toFixed(1) + ' px, its line ' + m.chart.line_left.toFixed(1) +
             '..' + m.chart.line_right.toFixed(1) + ' px: the axis is not the sweep');
    }
    if (!m.verdicts.length) f.push('no verdict groups');
    if (m.verdict_rows_outside_groups) f.push('verdict rows outside the groups');
    for (const g of m.verdicts) {
      if (!g.summary) f.push('verdict group ' + g.group + ' has no summary line');
      if (g.shown > Math.max(5, g.failing))
        f.push('verdict group ' + g.group + ' shows ' + g.shown + ' rows unfolded');
    }
    if (!m.verdicts.some((g) => g.folded > 0)) f.push('no verdict rows folded');
    return f;
  }

  const started = Date.now();
  (function wait() {
    const status = document.getElementById('render-status').dataset.status;
    if (status === 'pending' && Date.now() - started < 15000) {
      setTimeout(wait, 100);
      return;
    }
    let result;
    try {
      result = measure(status);
    } catch (e) {
      out.textContent = JSON.stringify({error: String(e),
                                        failures: ['the layout check failed: ' + String(e)]});
      return;
    }
    // The labels are placed again at every pose the slider shows: move it to four more samples
    // (a quarter of the sweep apart) and measure again.
    const slider = document.getElementById('sample');
    const n = Number(slider.max) + 1;
    const samples = [1, 2, 3, 4].map((i) => Math.min(n - 1, Math.round(i * n / 4)));
    result.slider = [];
    const drawn = slider.value;
    (function next(i) {
      if (i > 0) {
        const {boxes, overlaps} = labelOverlaps(document.querySelector('#drawing svg'));
        result.slider.push({sample: samples[i - 1], labels: boxes.length, overlaps,
                            shown: document.getElementById('sample-value').textContent});
        if (overlaps.length)
          result.failures.push('at sample ' + samples[i - 1] + ' of the slider, ' +
                               overlaps.length + ' pairs of labels overlap: ' + overlaps.join(', '));
      }
      if (i === samples.length) {  // back to the drawn pose, for the dumped DOM
        slider.value = drawn;
        slider.dispatchEvent(new Event('input'));
        setTimeout(() => { out.textContent = JSON.stringify(result); }, 300);
        return;
      }
      slider.value = String(samples[i]);
      slider.dispatchEvent(new Event('input'));
      setTimeout(() => next(i + 1), 300);
    })(0);
  })();
})();
