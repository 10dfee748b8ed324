// polymap report page: map replay, direction histogram and per-scan plots. No network.
(function () {
  'use strict';
  var errors = [];
  window.addEventListener('error', function (e) {
    errors.push(String((e && e.message) || e));
  });

  var PALETTE = ['#4e79a7', '#f28e2b', '#e15759', '#76b7b2', '#59a14f',
    '#edc948', '#b07aa1', '#ff9da7', '#9c755f', '#bab0ac'];
  var LOOSE = '#555555';
  var TRAJECTORY = '#d62728';
  var $ = function (id) { return document.getElementById(id); };
  var D = null, snaps = [], EXTENT = null;
  var state = { index: 0, view: null, timer: 0, drag: null, pending: false };

  // ---------------------------------------------------------------- data helpers

  function finite(v) { return typeof v === 'number' && isFinite(v); }

  function extent() {
    var b = { minX: Infinity, minY: Infinity, maxX: -Infinity, maxY: -Infinity };
    function add(x, y) {
      if (!finite(x) || !finite(y)) { return; }
      b.minX = Math.min(b.minX, x); b.maxX = Math.max(b.maxX, x);
      b.minY = Math.min(b.minY, y); b.maxY = Math.max(b.maxY, y);
    }
    function addFlat(a, stride) { for (var i = 0; i + 1 < a.length; i += stride) { add(a[i], a[i + 1]); } }
    addFlat(D.final_segments, 2);
    addFlat(D.trajectory_pose, 3);
    for (var k = 0; k < snaps.length; k++) { addFlat(snaps[k].segments, 2); }
    if (!finite(b.minX)) { b = { minX: -1, minY: -1, maxX: 1, maxY: 1 }; }
    return b;
  }

  // Index of the last trajectory pose at or before `scan` (binary search), -1 if none.
  function poseIndexAt(scan) {
    var lo = 0, hi = D.trajectory_scan.length - 1, found = -1;
    while (lo <= hi) {
      var mid = (lo + hi) >> 1;
      if (D.trajectory_scan[mid] <= scan) { found = mid; lo = mid + 1; } else { hi = mid - 1; }
    }
    return found;
  }

  function currentSnapshot() { return snaps.length ? snaps[state.index] : null; }
  function currentScan() {
    var s = currentSnapshot();
    return s ? s.scan : Math.max(0, D.total_scans - 1);
  }

  function roundLength(atMost) {
    if (!(atMost > 0) || !isFinite(atMost)) { return 1; }
    var decade = Math.pow(10, Math.floor(Math.log10(atMost)));
    var m = atMost / decade;
    return (m >= 5 ? 5 : m >= 2 ? 2 : 1) * decade;
  }

  function fmt(v, digits) {
    if (!finite(v)) { return '–'; }
    if (Math.abs(v) >= 1000) { return v.toFixed(0); }
    // Trailing zeros of the fraction only: 250 stays 250.
    var t = v.toPrecision(digits || 3);
    return t.indexOf('.') < 0 || t.indexOf('e') >= 0 ? t : t.replace(/\.?0+$/, '');
  }

  // ---------------------------------------------------------------- canvas helpers

  function setup(canvas) {
    var r = canvas.getBoundingClientRect();
    var dpr = window.devicePixelRatio || 1;
    var w = Math.max(1, Math.round(r.width * dpr)), h = Math.max(1, Math.round(r.height * dpr));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    var ctx = canvas.getContext('2d');
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, r.width, r.height);
    return { ctx: ctx, w: Math.max(1, r.width), h: Math.max(1, r.height), dpr: dpr };
  }

  // ---------------------------------------------------------------- map view

  function fit() {
    var r = $('map').getBoundingClientRect();
    var w = Math.max(1, r.width), h = Math.max(1, r.height);
    var bw = Math.max(EXTENT.maxX - EXTENT.minX, 1), bh = Math.max(EXTENT.maxY - EXTENT.minY, 1);
    state.view = {
      cx: (EXTENT.minX + EXTENT.maxX) / 2,
      cy: (EXTENT.minY + EXTENT.maxY) / 2,
      scale: 0.92 * Math.min(w / bw, h / bh)
    };
  }

  function toMap(c, px, py) {
    var v = state.view;
    return [v.cx + (px - c.w / 2) / v.scale, v.cy - (py - c.h / 2) / v.scale];
  }

  // Strokes segments given as a flat [x0, y0, x1, y1, ...] array, optionally filtered by `keep`.
  function strokeSegments(ctx, flat, colour, width, keep) {
    ctx.beginPath();
    for (var i = 0, k = 0; i + 3 < flat.length; i += 4, k++) {
      if (keep && !keep(k)) { continue; }
      ctx.moveTo(flat[i], flat[i + 1]);
      ctx.lineTo(flat[i + 2], flat[i + 3]);
    }
    ctx.strokeStyle = colour;
    ctx.lineWidth = width;
    ctx.stroke();
  }

  function drawFinalMap(ctx, px, faint) {
    if (faint) { strokeSegments(ctx, D.final_segments, '#dde1e6', 3 * px); return; }
    var groups = {};
    for (var k = 0; k < D.polyline_of.length; k++) { groups[D.polyline_of[k]] = true; }
    Object.keys(groups).forEach(function (g) {
      var id = Number(g);
      var colour = id < 0 ? LOOSE : PALETTE[id % PALETTE.length];
      strokeSegments(ctx, D.final_segments, colour, 2 * px, function (k) { return D.polyline_of[k] === id; });
    });
  }

  function drawTrajectory(ctx, px, upTo) {
    var p = D.trajectory_pose, started = false;
    ctx.beginPath();
    for (var i = 0; i <= upTo; i++) {
      var x = p[3 * i], y = p[3 * i + 1];
      if (!finite(x) || !finite(y)) { continue; }
      if (started) { ctx.lineTo(x, y); } else { ctx.moveTo(x, y); started = true; }
    }
    ctx.strokeStyle = TRAJECTORY;
    ctx.lineWidth = 1.2 * px;
    ctx.stroke();
  }

  function drawRobot(ctx, px, pose) {
    if (!pose || !finite(pose[0]) || !finite(pose[1])) { return; }
    var r = 9 * px, c = Math.cos(pose[2] || 0), s = Math.sin(pose[2] || 0);
    function at(fx, fy) { return [pose[0] + r * (c * fx - s * fy), pose[1] + r * (s * fx + c * fy)]; }
    var a = at(1.2, 0), b = at(-0.7, 0.65), d = at(-0.7, -0.65);
    ctx.beginPath();
    ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]); ctx.lineTo(d[0], d[1]); ctx.closePath();
    ctx.fillStyle = TRAJECTORY; ctx.fill();
    ctx.strokeStyle = '#fff'; ctx.lineWidth = 1.5 * px; ctx.stroke();
  }

  function drawScaleBar(c) {
    var ctx = c.ctx, len = roundLength(0.2 * c.w / state.view.scale), barPx = len * state.view.scale;
    var x0 = 14, y = c.h - 14;
    ctx.strokeStyle = '#000'; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(x0, y - 6); ctx.lineTo(x0, y); ctx.lineTo(x0 + barPx, y); ctx.lineTo(x0 + barPx, y - 6); ctx.stroke();
    ctx.fillStyle = '#000'; ctx.font = '12px sans-serif';
    ctx.fillText(fmt(len, 3) + ' m', x0, y - 9);
  }

  function drawMap() {
    var c = setup($('map'));
    if (!state.view) { fit(); }
    var v = state.view, ctx = c.ctx, px = 1 / v.scale;
    ctx.fillStyle = '#fff'; ctx.fillRect(0, 0, c.w, c.h);
    ctx.save();
    ctx.setTransform(c.dpr * v.scale, 0, 0, -c.dpr * v.scale,
      c.dpr * (c.w / 2 - v.cx * v.scale), c.dpr * (c.h / 2 + v.cy * v.scale));
    ctx.lineCap = 'round'; ctx.lineJoin = 'round';
    // At the last snapshot the final map is shown in its polyline colours (if there is one).
    var snap = currentSnapshot(), hasFinal = D.final_segments.length > 0;
    var showFinalColours = hasFinal && (!snap || state.index === snaps.length - 1);
    if ($('show-final').checked || showFinalColours) { drawFinalMap(ctx, px, !showFinalColours); }
    if (snap && !showFinalColours) { strokeSegments(ctx, snap.segments, '#1f4e79', 2 * px); }
    var poseIndex = poseIndexAt(currentScan());
    if ($('show-trajectory').checked) { drawTrajectory(ctx, px, poseIndex); }
    drawRobot(ctx, px, snap ? snap.pose : null);
    ctx.restore();
    drawScaleBar(c);
  }

  // ---------------------------------------------------------------- histogram

  function drawHistogram() {
    var c = setup($('histogram')), ctx = c.ctx, snap = currentSnapshot();
    var hist = snap ? snap.histogram_m : [], dirs = snap ? snap.directions_deg : [];
    var left = 34, bottom = 18, w = c.w - left - 6, h = c.h - bottom - 6;
    var max = 0;
    for (var i = 0; i < hist.length; i++) { if (finite(hist[i])) { max = Math.max(max, hist[i]); } }
    max = max > 0 ? max : 1;
    ctx.fillStyle = '#4e79a7';
    var bw = w / Math.max(hist.length, 1);
    for (i = 0; i < hist.length; i++) {
      if (!finite(hist[i]) || hist[i] <= 0) { continue; }
      var bh = h * hist[i] / max;
      ctx.fillRect(left + i * bw, 6 + h - bh, Math.max(bw - 0.5, 0.5), bh);
    }
    axes(ctx, left, 6, w, h, 0, 180, 0, max, [0, 45, 90, 135, 180], '°', 'm');
    ctx.strokeStyle = TRAJECTORY; ctx.fillStyle = TRAJECTORY; ctx.lineWidth = 1.5;
    dirs.forEach(function (d) {
      var x = left + w * d / 180;
      ctx.beginPath(); ctx.moveTo(x, 6); ctx.lineTo(x, 6 + h); ctx.stroke();
      ctx.fillText(fmt(d, 3) + '°', Math.min(x + 3, left + w - 36), 16);
    });
    $('directions').textContent = dirs.length
      ? 'Main directions: ' + dirs.map(function (d) { return fmt(d, 4) + '°'; }).join(', ')
      : 'No main direction at this time.';
  }

  function axes(ctx, x, y, w, h, x0, x1, y0, y1, xticks, xunit, yunit) {
    ctx.strokeStyle = '#8c959f'; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(x, y); ctx.lineTo(x, y + h); ctx.lineTo(x + w, y + h); ctx.stroke();
    ctx.fillStyle = '#656d76'; ctx.font = '10px sans-serif';
    xticks.forEach(function (t) {
      var tx = x + w * (t - x0) / Math.max(x1 - x0, 1e-12);
      ctx.fillText(fmt(t, 4) + xunit, Math.min(tx - 6, x + w - 24), y + h + 12);
    });
    ctx.fillText(fmt(y1, 3), 2, y + 8);
    ctx.fillText(fmt(y0, 3), 2, y + h);
    if (yunit) { ctx.fillText(yunit, 2, y + h / 2); }
  }

  // ---------------------------------------------------------------- per-scan plots

  function niceTicks(max) {
    var step = roundLength(max / 4), out = [];
    for (var t = 0; t <= max + 1e-9; t += step) { out.push(t); }
    return out;
  }

  function drawPlot(canvasId, titleId, list, colours) {
    var c = setup($(canvasId)), ctx = c.ctx;
    var left = 44, w = c.w - left - 8, h = c.h - 24, top = 6;
    var xmax = Math.max(D.total_scans - 1, 1), ymin = Infinity, ymax = -Infinity;
    list.forEach(function (s) {
      s.value.forEach(function (v) { if (finite(v)) { ymin = Math.min(ymin, v); ymax = Math.max(ymax, v); } });
    });
    if (!finite(ymin)) { ymin = 0; ymax = 1; }
    ymin = Math.min(ymin, 0);
    if (ymax <= ymin) { ymax = ymin + 1; }
    list.forEach(function (s, k) {
      ctx.beginPath();
      for (var i = 0; i < s.scan.length; i++) {
        var X = left + w * s.scan[i] / xmax, Y = top + h - h * (s.value[i] - ymin) / (ymax - ymin);
        if (i === 0) { ctx.moveTo(X, Y); } else { ctx.lineTo(X, Y); }
      }
      ctx.strokeStyle = colours[k]; ctx.lineWidth = 1.2; ctx.stroke();
    });
    axes(ctx, left, top, w, h, 0, xmax, ymin, ymax, niceTicks(xmax), '', list[0].unit);
    // Weak stretches (consecutive weak scans over at least 10 m), a yellow band along the
    // bottom.
    ctx.fillStyle = 'rgba(220, 170, 0, 0.45)';
    (D.weak_stretches || []).forEach(function (r) {
      var x0 = left + w * r[0] / xmax, x1 = left + w * (r[1] + 1) / xmax;
      ctx.fillRect(x0, top + h - Math.max(4, h / 6), Math.max(1, x1 - x0), Math.max(4, h / 6));
    });
    // Scans where tracking was lost, shaded across the plot.
    ctx.fillStyle = 'rgba(200, 30, 30, 0.25)';
    (D.lost_ranges || []).forEach(function (r) {
      var x0 = left + w * r[0] / xmax, x1 = left + w * (r[1] + 1) / xmax;
      ctx.fillRect(x0, top, Math.max(1, x1 - x0), h);
    });
    // Scans that follow a gap in the log (scans missing there), a thin mark each.
    ctx.fillStyle = 'rgba(230, 140, 0, 0.8)';
    (D.gap_scans || []).forEach(function (t) {
      ctx.fillRect(left + w * t / xmax - 0.5, top, 1, h);
    });
    // Scans whose tracked step the log's odometry contradicts, a short purple mark each
    // along the top.
    ctx.fillStyle = 'rgba(130, 40, 170, 0.8)';
    (D.off_odometry_scans || []).forEach(function (t) {
      ctx.fillRect(left + w * t / xmax - 0.5, top, 1, Math.max(4, h / 6));
    });
    var cx = left + w * currentScan() / xmax;
    ctx.strokeStyle = TRAJECTORY; ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.moveTo(cx, top); ctx.lineTo(cx, top + h); ctx.stroke();
    $(titleId).textContent = list.map(function (s, k) {
      return (k ? ' · ' : '') + s.name + (k ? ' (grey)' : '') + ' at scan ' + currentScan() + ': ' + fmt(valueAt(s, currentScan()), 4) + (s.unit ? ' ' + s.unit : '');
    }).join('');
  }

  // The last kept value at or before `scan`.
  function valueAt(s, scan) {
    var best = NaN;
    for (var i = 0; i < s.scan.length && s.scan[i] <= scan; i++) { best = s.value[i]; }
    return best;
  }

  // ---------------------------------------------------------------- page

  function updateText() {
    var snap = currentSnapshot(), scan = currentScan();
    $('map-scan').textContent = String(scan);
    $('hist-scan').textContent = String(scan);
    var lost = (D.lost_ranges || []).some(function (r) { return r[0] <= scan && scan <= r[1]; });
    var gap = (D.gap_scans || []).indexOf(scan) >= 0;
    var off = (D.off_odometry_scans || []).indexOf(scan) >= 0;
    var stretch = (D.weak_stretches || []).some(function (r) { return r[0] <= scan && scan <= r[1]; });
    $('slider-label').textContent = 'scan ' + scan + (lost ? ' (tracking lost)' : '') +
      (gap ? ' (after a gap in the log)' : '') +
      (off ? ' (step off the odometry)' : '') +
      (stretch ? ' (in a weak stretch)' : '') + ' of ' + D.total_scans +
      ' · snapshot ' + (snaps.length ? state.index + 1 : 0) + '/' + snaps.length;
    var rows = [
      ['segments at this time', snap ? snap.segments.length / 4 : '–'],
      ['segments in final map', D.final_segments.length / 4],
      ['polylines in final map', countPolylines()],
      ['scans', D.total_scans],
      ['snapshots stored', snaps.length],
      ['trajectory poses stored', D.trajectory_scan.length]
    ];
    var gaps = D.gaps || (D.gap_scans || []).length;
    if (gaps) {
      rows.push(['scans after a gap in the log (orange marks)', gaps]);
    }
    var offCount = D.off_odometry || (D.off_odometry_scans || []).length;
    if (offCount) {
      rows.push(['scans whose step the odometry contradicts (purple marks)', offCount]);
    }
    var stretches = (D.weak_stretches || []).length;
    if (stretches) {
      rows.push(['weak stretches of 10 m or more (yellow bands)', stretches]);
    }
    var mc = D.map_consistency;
    if (mc) {
      rows.push(['walls seen through, per sighting', fmt(100 * mc.seen_through_share, 3) + ' %' +
        (mc.seen_through_share > mc.warn_above ? ' (above ' + fmt(100 * mc.warn_above, 3) +
          ' %: the map is likely inconsistent)' : '')]);
      if (mc.crossed_share !== undefined && mc.crossed_share !== null) {
        rows.push(['map length drawn twice about walls crossing at 5-30°',
          fmt(100 * mc.crossed_share, 3) + ' %' + (mc.crossed_share > mc.warn_crossed_above ?
            ' (above ' + fmt(100 * mc.warn_crossed_above, 3) +
            ' %: walls drawn twice, turned apart)' : '')]);
      }
      if (mc.walls_seen_through_share !== undefined && mc.walls_seen_through_share !== null) {
        var over = mc.walls_seen_through_share > mc.warn_walls_above;
        // The five longest ranges, in scan order, as the run's warning names them.
        var named = (mc.seen_through_scans || []).slice().sort(function (a, b) {
          return (b[1] - b[0]) - (a[1] - a[0]) || a[0] - b[0];
        }).slice(0, 5).sort(function (a, b) { return a[0] - b[0]; }).map(function (r) {
          return r[0] === r[1] ? String(r[0]) : r[0] + '-' + r[1];
        }).join(', ');
        rows.push(['walls of 1 m or more seen through, every second observing scan at its final pose',
          fmt(100 * mc.walls_seen_through_share, 3) + ' %' + (over ?
            ' (above ' + fmt(100 * mc.warn_walls_above, 3) +
            ' %: the map is likely inconsistent' + (named ? '; placed by scans ' + named : '') +
            ')' : '')]);
      }
    }
    var table = $('counts');
    table.textContent = '';
    rows.forEach(function (r) {
      var tr = table.insertRow(), a = tr.insertCell(), b = tr.insertCell();
      a.textContent = r[0]; b.textContent = String(r[1]);
    });
  }

  function countPolylines() {
    var seen = {}, n = 0;
    D.polyline_of.forEach(function (k) { if (k >= 0 && !seen[k]) { seen[k] = true; n++; } });
    return n;
  }

  function drawAll() {
    state.pending = false;
    updateText();
    drawMap();
    drawHistogram();
    drawPlot('plot0', 'plot0-title', [D.series[0]], ['#1f4e79']);
    drawPlot('plot1', 'plot1-title', [D.series[1], D.series[2]], ['#1f4e79', '#9aa0a6']);
  }

  function schedule() {
    if (state.pending) { return; }
    state.pending = true;
    window.requestAnimationFrame(drawAll);
  }

  function setIndex(i) {
    state.index = Math.max(0, Math.min(snaps.length - 1, i | 0));
    $('slider').value = String(state.index);
    schedule();
  }

  function togglePlay() {
    if (state.timer) {
      window.clearInterval(state.timer); state.timer = 0; $('play').textContent = '▶';
      return;
    }
    if (state.index >= snaps.length - 1) { setIndex(0); }
    $('play').textContent = '❚❚';
    var step = Math.max(1, Math.round(snaps.length / 150));
    state.timer = window.setInterval(function () {
      if (state.index >= snaps.length - 1) { togglePlay(); return; }
      setIndex(state.index + step);
    }, 60);
  }

  function onWheel(e) {
    e.preventDefault();
    var r = $('map').getBoundingClientRect(), c = { w: r.width, h: r.height };
    var px = e.clientX - r.left, py = e.clientY - r.top;
    var before = toMap(c, px, py), v = state.view;
    v.scale *= Math.exp(-e.deltaY * 0.0015);
    var after = toMap(c, px, py);
    v.cx += before[0] - after[0]; v.cy += before[1] - after[1];
    schedule();
  }

  function bindMapMouse() {
    var map = $('map');
    map.addEventListener('wheel', onWheel, { passive: false });
    map.addEventListener('mousedown', function (e) {
      state.drag = { x: e.clientX, y: e.clientY, cx: state.view.cx, cy: state.view.cy };
      map.classList.add('dragging');
    });
    window.addEventListener('mouseup', function () { state.drag = null; map.classList.remove('dragging'); });
    window.addEventListener('mousemove', function (e) {
      var r = map.getBoundingClientRect();
      var p = toMap({ w: r.width, h: r.height }, e.clientX - r.left, e.clientY - r.top);
      $('cursor-pos').textContent = 'x ' + p[0].toFixed(2) + ' m, y ' + p[1].toFixed(2) + ' m';
      if (!state.drag) { return; }
      var s = state.view.scale;
      state.view.cx = state.drag.cx - (e.clientX - state.drag.x) / s;
      state.view.cy = state.drag.cy + (e.clientY - state.drag.y) / s;
      schedule();
    });
  }

  function init() {
    $('summary').textContent = D.total_scans + ' scans · ' + D.final_segments.length / 4 +
      ' segments · ' + countPolylines() + ' polylines';
    var slider = $('slider');
    slider.max = String(Math.max(0, snaps.length - 1));
    slider.value = String(state.index);
    slider.disabled = snaps.length < 2;
    slider.addEventListener('input', function () { setIndex(Number(slider.value)); });
    $('play').addEventListener('click', togglePlay);
    $('fit').addEventListener('click', function () { fit(); schedule(); });
    $('show-final').addEventListener('change', schedule);
    $('show-trajectory').addEventListener('change', schedule);
    window.addEventListener('resize', schedule);
    window.addEventListener('keydown', function (e) {
      if (e.target === slider) { return; }
      if (e.key === 'ArrowRight') { setIndex(state.index + 1); }
      if (e.key === 'ArrowLeft') { setIndex(state.index - 1); }
    });
    bindMapMouse();
    drawAll();
  }

  // ---------------------------------------------------------------- self-test (#selftest)

  function inkedPixels(canvas) {
    var data = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data, n = 0;
    for (var i = 0; i < data.length; i += 4) { if (data[i] < 200 || data[i + 1] < 200) { n++; } }
    return n;
  }

  function selftestSteps() {
    var slider = $('slider'), n = snaps.length, checks = 0;
    var positions = [0, n >> 2, n >> 1, n - 1, 1, (3 * n) >> 2, n - 1];
    positions.forEach(function (p) {
      if (p < 0 || p >= n) { return; }
      slider.value = String(p);
      slider.dispatchEvent(new Event('input', { bubbles: true }));
      drawAll();
      if (state.index !== p) { throw new Error('slider to ' + p + ' left index ' + state.index); }
      if ($('map-scan').textContent !== String(snaps[p].scan)) { throw new Error('map label not updated at ' + p); }
      checks++;
    });
    var scale = state.view.scale, r = $('map').getBoundingClientRect();
    $('map').dispatchEvent(new WheelEvent('wheel', { deltaY: -300, clientX: r.left + r.width / 2, clientY: r.top + r.height / 2, bubbles: true, cancelable: true }));
    if (!(state.view.scale > scale)) { throw new Error('wheel did not zoom in'); }
    $('fit').click();
    drawAll();
    if (D.final_segments.length && inkedPixels($('map')) < 50) { throw new Error('map canvas is blank'); }
    if (n && inkedPixels($('histogram')) < 10) { throw new Error('histogram canvas is blank'); }
    return checks;
  }

  function selftest() {
    var out = $('selftest');
    try {
      var checks = selftestSteps();
      if (errors.length) { throw new Error('script error: ' + errors.join('; ')); }
      out.textContent = 'SELFTEST PASS (' + checks + ' slider positions, ' + snaps.length + ' snapshots)';
    } catch (e) {
      out.textContent = 'SELFTEST FAIL: ' + ((e && e.message) || String(e));
    }
  }

  // `#scan=N` in the URL opens the page at the last snapshot at or before scan N.
  function indexFromHash() {
    var m = /scan=(\d+)/.exec(window.location.hash);
    if (!m) { return; }
    var scan = Number(m[1]), i = 0;
    while (i + 1 < snaps.length && snaps[i + 1].scan <= scan) { i++; }
    state.index = i;
  }

  try {
    D = JSON.parse($('report-data').textContent);
    snaps = D.snapshots;
    state.index = Math.max(0, snaps.length - 1);
    EXTENT = extent();
    indexFromHash();
    init();
  } catch (e) {
    errors.push('init: ' + ((e && e.message) || String(e)));
  }
  if (window.location.hash === '#selftest') {
    if (errors.length) {
      $('selftest').textContent = 'SELFTEST FAIL: ' + errors.join('; ');
    } else {
      selftest();
    }
  }
})();
