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
  // One colour and dash per method in every report, from the engine table and the exact methods'
  // (methods::method_style); solid where the dash is empty.
  const style = (m) => {
    const s = (R.styles || {})[m] || {colour: '#8c564b', dash: [1, 1]};
    return {colour: s.colour, dash: s.dash.length ? s.dash : [1, 0]};
  };
  // Two methods drawn alike could not be told apart: an error of the page.
  {
    const seen = new Map();
    for (const m of methodOrder) {
      const key = JSON.stringify(style(m));
      if (seen.has(key)) throw new Error(m + ' is drawn as ' + seen.get(key) + ' is');
      seen.set(key, m);
    }
  }
  const driverSpan = (() => {
    let lo = Infinity, hi = -Infinity;
    for (const v of R.driver.values) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
    return lo < hi ? [lo, hi] : [lo - 1, hi + 1];  // one sample: a span around it
  })();
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
    // The axis spans the sweep, from its first driver value (a sweep from 90 deg starts at 90).
    const axisX = {field: 'driver', type: 'quantitative', title: driverTitle,
                   scale: {domain: driverSpan, nice: false, zero: false}};
    // Colour and dash share the field and title, so one legend shows both.
    const colour = {field: 'method', type: 'nominal', scale: colorScale, title: 'method'};
    const dash = {field: 'method', type: 'nominal', scale: dashScale, title: 'method'};
    const flaggedRule = {data: {name: 'flagged'},
                         mark: {type: 'rect', color: '#d62728', opacity: 0.15},
                         encoding: {x: axisX, x2: {field: 'driver2'},
                                    tooltip: [{field: 'reason'}]}};
    // Several drivers' singular positions (direct, inverse): a rule at each located time.
    const singularRule = {data: {values: R.singular || []},
                          mark: {type: 'rule', color: '#9467bd', strokeWidth: 1.5},
                          encoding: {x: axisX, tooltip: [{field: 'kind'}, {field: 'message'}]}};
    const singularLabel = {data: {values: R.singular || []},
                           mark: {type: 'text', align: 'left', baseline: 'top', dx: 3, dy: 2,
                                  color: '#9467bd', fontSize: 10},
                           encoding: {x: axisX, y: {value: 0}, text: {field: 'kind'}}};
    // The [[derived]] dead points (one driver: the axis is its value) on every chart, and a
    // stroke's ends on its channel's.
    const deadRule = {data: {values: R.dead_points || []},
                      mark: {type: 'rule', color: '#2ca02c', strokeDash: [6, 3], clip: true},
                      encoding: {x: axisX, tooltip: [{field: 'label'}]}};
    const deadLabel = {data: {values: R.dead_points || []},
                       mark: {type: 'text', align: 'left', baseline: 'top', dx: 3, dy: 2,
                              color: '#2ca02c', fontSize: 10, clip: true},
                       encoding: {x: axisX, y: {value: 0}, text: {field: 'label'}}};
    const yTitle = name + ' [' + unit + ']';
    const strokeRows = [];
    for (const s of (R.strokes || []))
      if (s.channel === name)
        for (const end of ['min', 'max'])
          strokeRows.push({value: s[end], label: s.label + ' (' + end + ')'});
    const strokeRule = {data: {values: strokeRows},
                        mark: {type: 'rule', color: '#8c564b', strokeDash: [2, 3]},
                        encoding: {y: {field: 'value', type: 'quantitative', title: yTitle},
                                   tooltip: [{field: 'label'}]}};
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
            flaggedRule, singularRule, singularLabel, deadRule, deadLabel, strokeRule, cursor,
            {data: {name: 'series'},
             mark: {type: 'line', strokeWidth: 1.6, clip: true, invalid: gaps},
             encoding: {x: axisX, y: {field: 'value', type: 'quantitative',
                                        title: yTitle, scale: {zero: false}},
                        color: colour, strokeDash: dash,
                        tooltip: [{field: 'method'}, {field: 'driver', format: '.2f'},
                                  {field: 'value', format: '.6g'}]}},
          ],
        },
        {
          width: 640, height: 130,
          layer: [
            flaggedRule, singularRule, deadRule, cursor,
            {data: {name: 'series'},
             transform: [{filter: 'datum.method != ' + JSON.stringify(methodOrder[0])}],
             mark: {type: 'line', strokeWidth: 1.2, clip: true, invalid: gaps},
             encoding: {x: axisX,
                        // '~g': differences of 1e-13 % read as 1e-13, not as 0.0000000000001
                        y: {field: 'pct', type: 'quantitative', title: 'difference [% of peak]',
                            axis: {format: '.2~g'}},
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
  if (!R.driver.title || D.timed) {  // several drivers: the axis and D.at are times
    for (let k = 0; k < R.driver.values.length; k++)
      if (Math.abs(R.driver.values[k] - D.at) < Math.abs(R.driver.values[k0] - D.at)) k0 = k;
  }
  // Coincident centres share one name ("I1,2 = I3,4"), so that labels do not overprint.
  function centreGroups() {
    const groups = new Map();
    for (const c of D.centres) {
      const key = c.x.toPrecision(6) + ',' + c.y.toPrecision(6);
      if (!groups.has(key)) groups.set(key, {x: c.x, y: c.y, names: [], how: []});
      groups.get(key).names.push(c.name);
      groups.get(key).how.push(c.name + ': ' + c.how);
    }
    return [...groups.values()].map((g) => ({x: g.x, y: g.y, name: g.names.join(' = '),
                                               how: g.how.join('; ')}));
  }
  // Paths of the moving points over the sweep (coupler curves), broken where a sample has none.
  const pathRows = (() => {
    const rows = [];
    for (const p of D.points) {
      if (p.kind === 'ground pivot') continue;
      for (let k = 0; k < R.driver.values.length; k++)
        rows.push({name: p.name, k, x: at('x.' + p.name, k), y: at('y.' + p.name, k)});
    }
    return rows;
  })();
  // The linkage at each dead point (the sample nearest it), in faint green: where the output
  // turns back, the limit positions a designer draws.
  const deadPoseRows = (() => {
    const rows = [];
    for (const d of (R.dead_points || [])) {
      let k = 0;
      for (let j = 1; j < R.driver.values.length; j++)
        if (Math.abs(R.driver.values[j] - d.driver) < Math.abs(R.driver.values[k] - d.driver)) k = j;
      for (const s of D.segments) {
        const row = {label: d.label, x: at('x.' + s.p, k), y: at('y.' + s.p, k),
                     x2: at('x.' + s.q, k), y2: at('y.' + s.q, k)};
        if (row.x !== null && row.y !== null && row.x2 !== null && row.y2 !== null) rows.push(row);
      }
    }
    return rows;
  })();

  // The frame: the linkage's extent over the sweep (every point at every sample, and the drawn
  // pose) with a margin, at one scale on both axes, as large as the page allows in the
  // linkage's longer direction. Nothing else sets it: a centre outside it is an arrow at its edge, and guides
  // and reactions are clipped.
  const frame = (() => {
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    const add = (x, y) => {
      if (x === null || y === null) return;
      x0 = Math.min(x0, x); x1 = Math.max(x1, x); y0 = Math.min(y0, y); y1 = Math.max(y1, y);
    };
    for (const p of D.points) add(p.x, p.y);
    for (const r of pathRows) add(r.x, r.y);
    for (const c of D.cams || [])  // a cam's profile turns within its reach about its centre
      for (const p of c.poses)
        if (p) {
          add(p.centre[0] - c.reach, p.centre[1] - c.reach);
          add(p.centre[0] + c.reach, p.centre[1] + c.reach);
        }
    const margin = 28, maxWidth = 640, maxHeight = 560, minWidth = 400, minHeight = 240;
    const size = Math.max(x1 - x0, y1 - y0) || 1;  // a still point: any scale
    const ex = Math.max(x1 - x0, 1e-9 * size), ey = Math.max(y1 - y0, 1e-9 * size);
    const s = Math.min((maxWidth - 2 * margin) / ex, (maxHeight - 2 * margin) / ey);  // px per unit
    const width = Math.max(minWidth, Math.min(maxWidth, ex * s + 2 * margin));
    const height = Math.max(minHeight, Math.min(maxHeight, ey * s + 2 * margin));
    const left = (x0 + x1) / 2 - width / (2 * s), bottom = (y0 + y1) / 2 - height / (2 * s);
    return {
      s, width, height, left, bottom,
      toPx: (x, y) => [(x - left) * s, height - (y - bottom) * s],
      fromPx: (px, py) => [left + px / s, bottom + (height - py) / s],
      inside: (px, py) => px >= 0 && px <= width && py >= 0 && py <= height,
    };
  })();

  // Label placement, greedy in pixels: each label in turn (points first, then centres, arrows,
  // reactions) takes the first candidate position around its anchor (nearest ring first) whose
  // box stays in the frame and meets no placed label, marker, link, arrow or leader line; one
  // away from its anchor gets a leader line. A label with no room is left out and listed under
  // the drawing (its tooltip keeps it).
  const textWidth = (() => {
    const ctx = document.createElement('canvas').getContext('2d');
    return (text, size) => {
      ctx.font = size + 'px sans-serif';
      return ctx.measureText(text).width;
    };
  })();
  const overlaps = (a, b) => a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
  // Whether segment (a, b) passes within hw of box r (Liang-Barsky clip on the grown box).
  function crosses(r, s) {
    const x0 = r.x0 - s.hw, x1 = r.x1 + s.hw, y0 = r.y0 - s.hw, y1 = r.y1 + s.hw;
    const dx = s.bx - s.ax, dy = s.by - s.ay;
    let t0 = 0, t1 = 1;
    for (const [p, q] of [[-dx, s.ax - x0], [dx, x1 - s.ax], [-dy, s.ay - y0], [dy, y1 - s.ay]]) {
      if (p === 0) {
        if (q < 0) return false;
      } else {
        const t = q / p;
        if (p < 0) t0 = Math.max(t0, t); else t1 = Math.min(t1, t);
        if (t0 > t1) return false;
      }
    }
    return true;
  }
  const directions = [[1, -1], [1, 0], [-1, -1], [-1, 0], [1, 1], [-1, 1], [0, -1], [0, 1]];
  const rings = [2, 7, 13, 21, 31, 44, 60, 80];
  function placeLabels(items, boxes, segments) {
    const placed = [], leaders = [], left = [];
    for (const it of items) {
      const w = textWidth(it.text, it.size) + 2, h = it.size * 1.25;
      let found = null;
      for (const r of rings) {
        for (const [ux, uy] of directions) {
          const gap = it.clear + r;
          const cx = it.px + ux * (gap + w / 2), cy = it.py + uy * (gap + h / 2);
          const box = {x0: cx - w / 2, x1: cx + w / 2, y0: cy - h / 2, y1: cy + h / 2};
          if (box.x0 < 1 || box.y0 < 1 || box.x1 > frame.width - 1 || box.y1 > frame.height - 1)
            continue;
          if (boxes.some((b) => overlaps(box, b)) || segments.some((s) => crosses(box, s)))
            continue;
          // A leader from the anchor's marker to the box's nearest point.
          let leader = null;
          if (r > rings[1]) {
            const nx = Math.min(Math.max(it.px, box.x0), box.x1);
            const ny = Math.min(Math.max(it.py, box.y0), box.y1);
            const d = Math.hypot(nx - it.px, ny - it.py);
            leader = {ax: it.px + (nx - it.px) * it.clear / d, ay: it.py + (ny - it.py) * it.clear / d,
                      bx: nx, by: ny, hw: 0.5};
            const inner = {x0: box.x0 + 1, x1: box.x1 - 1, y0: box.y0 + 1, y1: box.y1 - 1};
            if (placed.some((p) => crosses(p.box, leader) && !overlaps(p.box, inner))) continue;
          }
          found = {box, cx, cy, leader};
          break;
        }
        if (found) break;
      }
      if (!found) {
        left.push(it.text);
        continue;
      }
      boxes.push(found.box);
      if (found.leader) {
        segments.push(found.leader);
        const [x, y] = frame.fromPx(found.leader.ax, found.leader.ay);
        const [x2, y2] = frame.fromPx(found.leader.bx, found.leader.by);
        leaders.push({x, y, x2, y2});
      }
      const [x, y] = frame.fromPx(found.cx, found.cy);
      placed.push({box: found.box, kind: it.kind, text: it.text, x, y});
    }
    return {placed, leaders, left};
  }

  // Centres inside the frame are drawn where they are; the others as an arrow at the frame's
  // edge pointing at them, labelled with their name and distance beyond the arrow's tip.
  function centreMarks() {
    const inFrame = [], arrows = [];
    const mx = frame.width / 2, my = frame.height / 2, inset = 6, length = 30;
    for (const c of centreGroups()) {
      const [px, py] = frame.toPx(c.x, c.y);
      if (frame.inside(px, py)) {
        inFrame.push({...c, px, py});
        continue;
      }
      const d = Math.hypot(px - mx, py - my), ux = (px - mx) / d, uy = (py - my) / d;
      const reach = Math.min(ux ? (mx - inset) / Math.abs(ux) : Infinity,
                             uy ? (my - inset) / Math.abs(uy) : Infinity);
      const tip = [mx + ux * reach, my + uy * reach], tail = [tip[0] - ux * length, tip[1] - uy * length];
      const [x, y] = frame.fromPx(...tail), [x2, y2] = frame.fromPx(...tip);
      const beyond = Math.hypot(c.x - x2, c.y - y2);
      arrows.push({name: c.name, how: c.how, x, y, x2, y2, px: (tail[0] + tip[0]) / 2,
                   py: (tail[1] + tip[1]) / 2, tail, tip,
                   // Clockwise from up, as Vega turns a point's shape (pixel y grows down).
                   angle: Math.atan2(ux, -uy) * 180 / Math.PI,
                   // Three digits, never in exponent form ("1130 mm", not "1.13e+3 mm").
                   label: c.name + ' ' + Number(beyond.toPrecision(3)) + ' ' + D.unit + ' beyond',
                   cx: c.x, cy: c.y});
    }
    return {inFrame, arrows};
  }
  const centresAtK0 = centreMarks();

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
    const centres = here ? centresAtK0.inFrame : [], arrows = here ? centresAtK0.arrows : [];
    const forces = here ? D.forces : [];
    const cams = camsAt(k);

    // What labels must not cover: markers as boxes, links and arrows as thick segments.
    const boxes = [], lines = [];
    const marker = (px, py, r) => boxes.push({x0: px - r, x1: px + r, y0: py - r, y1: py + r});
    const line = (x, y, x2, y2, hw) => {
      const [ax, ay] = frame.toPx(x, y), [bx, by] = frame.toPx(x2, y2);
      lines.push({ax, ay, bx, by, hw});
    };
    for (const s of segments) line(s.x, s.y, s.x2, s.y2, 3.5);
    for (const f of forces) line(f.x, f.y, f.x2, f.y2, 1.5);
    for (const r of cams.rules) line(r.x, r.y, r.x2, r.y2, 1.5);
    for (const a of arrows) lines.push({ax: a.tail[0], ay: a.tail[1], bx: a.tip[0], by: a.tip[1], hw: 4});
    const items = [];
    for (const p of points) {
      const [px, py] = frame.toPx(p.x, p.y);
      marker(px, py, 5.5);
      items.push({kind: 'point', text: p.name, size: 13, px, py, clear: 5});
    }
    for (const c of centres) {
      marker(c.px, c.py, 4.5);
      items.push({kind: 'centre', text: c.name, size: 10, px: c.px, py: c.py, clear: 4});
    }
    for (const a of arrows)
      items.push({kind: 'arrow', text: a.label, size: 10, px: a.px, py: a.py, clear: 4});
    for (const f of forces) {
      const [px, py] = frame.toPx(f.x2, f.y2);
      if (frame.inside(px, py)) marker(px, py, 4.5);
      items.push({kind: 'force', text: f.label, size: 10, px, py, clear: 4});
    }
    for (const l of cams.labels) {
      const [px, py] = frame.toPx(l.x, l.y);
      items.push({kind: 'cam', text: l.text, size: 10, px, py, clear: 4});
    }
    const {placed, leaders, left} = placeLabels(items, boxes, lines);
    const of = (kind) => placed.filter((p) => p.kind === kind).map(({text, x, y}) => ({text, x, y}));
    return {
      segments, points,
      guides: D.guides.filter((g) => here || !g.moving),
      centres, arrows, forces,
      pointLabels: of('point'), centreLabels: of('centre'), arrowLabels: of('arrow'),
      forceLabels: of('force'), leaders, left,
      camProfiles: cams.profiles, camRollers: cams.rollers, camRules: cams.rules,
      camLabels: of('cam'),
    };
  }

  // Each cam at sample k (docs/cams.md, "Pressure angle"): its profile turned with it about its
  // centre, the roller, or the face through the contact, and from the roller's centre (the
  // face's contact) the common normal and the follower's direction of motion, the pressure angle
  // between them; nothing at a sample without a position.
  function camsAt(k) {
    const profiles = [], rollers = [], rules = [], labels = [];
    for (const c of D.cams || []) {
      const p = c.poses[k];
      if (!p) continue;
      const cos = Math.cos(p.angle), sin = Math.sin(p.angle);
      c.outline.concat([c.outline[0]]).forEach(([u, v], i) =>
        profiles.push({cam: c.name, i, x: p.centre[0] + cos * u - sin * v,
                       y: p.centre[1] + sin * u + cos * v}));
      for (let i = 0; c.roller > 0 && i <= 48; i++) {
        const t = 2 * Math.PI * i / 48;
        rollers.push({cam: c.name, i, x: p.at[0] + c.roller * Math.cos(t),
                      y: p.at[1] + c.roller * Math.sin(t)});
      }
      const reach = 0.5 * c.reach;
      const from = (d, length, kind, label) => rules.push({
        cam: c.name, kind, label, x: p.at[0], y: p.at[1], x2: p.at[0] + length * d[0],
        y2: p.at[1] + length * d[1]});
      const phi = c.name + ' pressure angle ' + p.phi.toFixed(2) + ' ' + c.angle_unit;
      from(p.normal, reach, 'common normal', phi);
      from(p.motion, reach, 'direction of motion', phi);
      if (c.face) {
        const t = [-p.normal[1], p.normal[0]];
        rules.push({cam: c.name, kind: 'face', label: c.name + ' face',
                    x: p.contact[0] - reach * t[0], y: p.contact[1] - reach * t[1],
                    x2: p.contact[0] + reach * t[0], y2: p.contact[1] + reach * t[1]});
      }
      labels.push({text: '\u03c6 ' + p.phi.toFixed(1) + ' ' + c.angle_unit,
                   x: p.at[0] + reach * p.normal[0], y: p.at[1] + reach * p.normal[1]});
    }
    return {profiles, rollers, rules, labels};
  }

  function drawingSpec() {
    const sx = {domain: [frame.left, frame.left + frame.width / frame.s], nice: false, zero: false};
    const sy = {domain: [frame.bottom, frame.bottom + frame.height / frame.s], nice: false,
                zero: false};
    const X = {field: 'x', type: 'quantitative', scale: sx, title: 'x [' + D.unit + ']'};
    const Y = {field: 'y', type: 'quantitative', scale: sy, title: 'y [' + D.unit + ']'};
    const X2 = {field: 'x2'}, Y2 = {field: 'y2'};
    const tipX = {field: 'x2', type: 'quantitative', scale: sx};
    const tipY = {field: 'y2', type: 'quantitative', scale: sy};
    const labels = (name, data, size, colour) => ({
      name, data: {name: data},
      mark: {type: 'text', align: 'center', baseline: 'middle', font: 'sans-serif',
             fontSize: size, color: colour},
      encoding: {x: X, y: Y, text: {field: 'text'}},
    });
    return {
      $schema: 'https://vega.github.io/schema/vega-lite/v6.json',
      width: frame.width, height: frame.height,
      datasets: {segments: [], points: [], guides: [], centres: [], arrows: [], forces: [],
                 pointLabels: [], centreLabels: [], arrowLabels: [], forceLabels: [], leaders: [],
                 camProfiles: [], camRollers: [], camRules: [], camLabels: []},
      // Layer names are the SVG groups' classes ("<name>_marks") the browser test measures.
      layer: [
        {name: 'paths', data: {values: pathRows},
         mark: {type: 'line', strokeWidth: 1, color: '#bbb', clip: true,
                invalid: 'break-paths-filter-domains'},
         encoding: {x: X, y: Y, detail: {field: 'name'}, order: {field: 'k'}}},
        {name: 'dead_poses', data: {values: deadPoseRows},
         mark: {type: 'rule', strokeWidth: 2, strokeDash: [4, 3], color: '#2ca02c', opacity: 0.5,
                clip: true},
         encoding: {x: X, y: Y, x2: X2, y2: Y2, tooltip: [{field: 'label'}]}},
        {name: 'guides', data: {name: 'guides'},
         mark: {type: 'rule', strokeDash: [6, 4], color: '#888', clip: true},
         encoding: {x: X, y: Y, x2: X2, y2: Y2}},
        // Cams: the profile, the roller, and the pressure angle's two rules.
        {name: 'cam_profiles', data: {name: 'camProfiles'},
         mark: {type: 'line', strokeWidth: 1.5, color: '#8c564b', clip: true},
         encoding: {x: X, y: Y, detail: {field: 'cam'}, order: {field: 'i'},
                    tooltip: [{field: 'cam'}]}},
        {name: 'cam_rollers', data: {name: 'camRollers'},
         mark: {type: 'line', strokeWidth: 1.5, color: '#555', clip: true},
         encoding: {x: X, y: Y, detail: {field: 'cam'}, order: {field: 'i'}}},
        {name: 'cam_rules', data: {name: 'camRules'},
         mark: {type: 'rule', strokeWidth: 1.5, color: '#9467bd', clip: true},
         encoding: {x: X, y: Y, x2: X2, y2: Y2,
                    strokeDash: {field: 'kind', type: 'nominal', title: 'cam',
                                 scale: {domain: ['common normal', 'direction of motion', 'face'],
                                         range: [[1, 0], [4, 3], [1, 0]]}},
                    tooltip: [{field: 'kind'}, {field: 'label'}]}},
        {name: 'links', data: {name: 'segments'},
         mark: {type: 'rule', strokeWidth: 5, opacity: 0.75, clip: true},
         encoding: {x: X, y: Y, x2: X2, y2: Y2,
                    color: {field: 'link', type: 'nominal', title: 'link'},
                    tooltip: [{field: 'link'}]}},
        {name: 'leaders', data: {name: 'leaders'},
         mark: {type: 'rule', strokeWidth: 0.7, color: '#777'},
         encoding: {x: X, y: Y, x2: X2, y2: Y2}},
        // Centres under the points, small and hollow, so that a centre at a pivot leaves it seen.
        {name: 'centres', data: {name: 'centres'},
         mark: {type: 'point', shape: 'diamond', filled: false, size: 50, color: '#d62728'},
         encoding: {x: X, y: Y, tooltip: [{field: 'name'}, {field: 'how'},
                                          {field: 'x', format: '.4f'}, {field: 'y', format: '.4f'}]}},
        {name: 'centre_arrows', data: {name: 'arrows'},
         mark: {type: 'rule', strokeWidth: 1.5, color: '#d62728'},
         encoding: {x: X, y: Y, x2: X2, y2: Y2,
                    tooltip: [{field: 'label'}, {field: 'how'}, {field: 'cx', format: '.4f'},
                              {field: 'cy', format: '.4f'}]}},
        {name: 'centre_arrow_heads', data: {name: 'arrows'},
         mark: {type: 'point', shape: 'triangle-up', filled: true, size: 50, color: '#d62728'},
         encoding: {x: tipX, y: tipY, angle: {field: 'angle', type: 'quantitative', scale: null},
                    tooltip: [{field: 'label'}]}},
        {name: 'points', data: {name: 'points'},
         mark: {type: 'point', filled: true, size: 70, color: '#222'},
         encoding: {x: X, y: Y,
                    shape: {field: 'kind', type: 'nominal', title: 'point',
                            scale: {domain: ['ground pivot', 'moving', 'slider block'],
                                    range: ['triangle-up', 'circle', 'square']}},
                    tooltip: [{field: 'name'}, {field: 'x', format: '.4f'},
                              {field: 'y', format: '.4f'}]}},
        // Joint reactions: first link on second, at the joint (exact kinetostatics).
        {name: 'forces', data: {name: 'forces'},
         mark: {type: 'rule', strokeWidth: 2, color: '#2ca02c', clip: true},
         encoding: {x: X, y: Y, x2: X2, y2: Y2, tooltip: [{field: 'label'}]}},
        {name: 'force_heads', data: {name: 'forces'},
         mark: {type: 'point', shape: 'triangle-up', filled: true, size: 60, color: '#2ca02c',
                clip: true},
         encoding: {x: tipX, y: tipY, angle: {field: 'angle', type: 'quantitative', scale: null},
                    tooltip: [{field: 'label'}]}},
        labels('point_labels', 'pointLabels', 13, '#000'),
        labels('centre_labels', 'centreLabels', 10, '#d62728'),
        labels('arrow_labels', 'arrowLabels', 10, '#d62728'),
        labels('force_labels', 'forceLabels', 10, '#2ca02c'),
        labels('cam_labels', 'camLabels', 10, '#9467bd'),
      ],
      title: D.effort ? {text: 'reactions (green, from ' + D.masses + '): first link on second; ' +
                               D.effort,
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
      const {left, ...pose} = poseAt(sample);
      for (const name of Object.keys(pose)) replace(result.view, name, pose[name]);
      const note = document.getElementById('drawing-left-out');
      if (note)
        note.textContent = left.length ? 'Labels left out for room (their marks have tooltips): ' +
                                         left.join(', ') + '.' : '';
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

  // A point's path in the plane: every method's (a gap where a sample has no position), in
  // sample order.
  function pathSpec(point) {
    const xs = R.channels['x.' + point], ys = R.channels['y.' + point];
    const rows = [];
    for (let k = 0; k < R.driver.values.length; k++) {
      rows.push({k, method: methodOrder[0], x: xs.ref[k], y: ys.ref[k]});
      for (const m of Object.keys(xs.methods))
        if (ys.methods[m]) rows.push({k, method: m, x: xs.methods[m].v[k], y: ys.methods[m].v[k]});
    }
    const colour = {field: 'method', type: 'nominal', scale: colorScale, title: 'method'};
    const dash = {field: 'method', type: 'nominal', scale: dashScale, title: 'method'};
    return {
      $schema: 'https://vega.github.io/schema/vega-lite/v6.json',
      data: {values: rows},
      padding: {left: 70, top: 5, right: 5, bottom: 5},
      width: 480, height: 360,
      mark: {type: 'line', strokeWidth: 1.4, invalid: 'break-paths-filter-domains'},
      encoding: {
        x: {field: 'x', type: 'quantitative', title: 'x.' + point + ' [' + xs.unit + ']',
            scale: {zero: false}},
        y: {field: 'y', type: 'quantitative', title: 'y.' + point + ' [' + ys.unit + ']',
            scale: {zero: false}},
        order: {field: 'k'},
        color: colour, strokeDash: dash,
        tooltip: [{field: 'method'}, {field: 'x', format: '.6g'}, {field: 'y', format: '.6g'}],
      },
    };
  }
  const pathSelect = document.getElementById('select-path');
  if (pathSelect && (R.paths || []).length) {
    for (const p of R.paths) {
      const o = document.createElement('option');
      o.value = p;
      o.textContent = p;
      pathSelect.appendChild(o);
    }
    const box = document.getElementById('chart-path');
    const show = (p) => vegaEmbed(box, pathSpec(p), opts);
    pathSelect.addEventListener('change', () => show(pathSelect.value));
    jobs.push(show(R.paths[0]));
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
