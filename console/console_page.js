// The console page: a Server-Sent Events stream of the run (snapshot, then
// bins, status, trip, ...), drawn with Plotly. Every string from the server
// is set as text (textContent), never as markup.
"use strict";
(function () {
  const token = new URLSearchParams(location.search).get("token") || "";
  const WINDOW_S = 20;  // of the time histories
  const MAX_LOOP_POINTS = 6000;
  const FORCE = ["Fx", "Fy", "Fz"];
  const CHANNELS = ["x", "y", "z", "toe", "camber", "caster"];
  const DEG = 180 / Math.PI;
  const colors = ["#1f77b4", "#d62728", "#2ca02c"];
  const body = document.body;
  const state = {run: null, bins: [], loop: [], pending: [], updates: 0,
                 dirty: false, redraw: true, iterations: 0};
  body.dataset.updates = "0";
  body.dataset.iterations = "0";

  function $(id) { return document.getElementById(id); }
  function text(id, value) { $(id).textContent = value; }
  function cell(row, value, cls) {
    const td = document.createElement("td");
    td.textContent = value;
    if (cls) td.className = cls;
    row.appendChild(td);
    return td;
  }
  function fmt(v, digits) {
    return v === null || v === undefined || !isFinite(v) ? "-" :
        Number(v).toFixed(digits);
  }

  // Signal i of a bin in display units: kN, mm, deg.
  function scale(i) {
    if (i < 6) return 1e-3;
    const k = (i - 6) % 6;
    return k < 3 ? 1e3 : DEG;
  }

  // Each bin as a vertical stroke from its min to its max: no spike hidden.
  function envelope(i, bins) {
    const x = [], y = [];
    const s = scale(i);
    for (const b of bins) {
      const t = 0.5 * (b[0] + b[1]);
      x.push(t, t);
      y.push(b[2][i] === null ? null : b[2][i] * s,
             b[3][i] === null ? null : b[3][i] * s);
    }
    return {x, y};
  }

  // Per name: the solid signal and the dashed one (command or model).
  function timeTraces(solid, dashed, names, dashedName, bins) {
    const traces = [];
    names.forEach((name, k) => {
      for (const [i, dash, label] of [[solid + k, "solid", name],
                                      [dashed + k, "dash",
                                       name + " " + dashedName]]) {
        const e = envelope(i, bins);
        traces.push({x: e.x, y: e.y, mode: "lines", name: label,
                     line: {color: colors[k], width: 1, dash}});
      }
    });
    return traces;
  }

  // The points `bins` add to timeTraces' traces, in their order.
  function timePoints(solid, dashed, bins) {
    const update = {x: [], y: []};
    for (let k = 0; k < 3; ++k) {
      for (const i of [solid + k, dashed + k]) {
        const e = envelope(i, bins);
        update.x.push(e.x);
        update.y.push(e.y);
      }
    }
    return update;
  }

  const layoutBase = {margin: {l: 50, r: 10, t: 10, b: 40}, uirevision: 1,
                      legend: {orientation: "h", y: -0.28},
                      xaxis: {title: {text: "t [s]"}}};
  const config = {displaylogo: false, responsive: true};

  function along(b) {
    const phi = state.run ? state.run.excitation.phi_deg / DEG : 0;
    return (b[4][3] * Math.cos(phi) + b[4][4] * Math.sin(phi)) * 1e-3;
  }

  function loopPoints(bins) {
    const update = {x: [], y: []};
    for (let k = 0; k < 6; ++k) {
      update.x.push(bins.map(along));
      update.y.push(bins.map((b) => b[4][6 + k] === null ? null :
                                 b[4][6 + k] * scale(6 + k)));
    }
    return update;
  }

  function loopTraces(bins) {
    const points = loopPoints(bins);
    return CHANNELS.map((name, k) => ({
      x: points.x[k], y: points.y[k], mode: "lines", name,
      xaxis: "x" + (k ? k + 1 : ""), yaxis: "y" + (k ? k + 1 : ""),
      line: {width: 1, color: colors[k % 3]}, showlegend: false}));
  }

  function loopLayout() {
    const layout = {margin: {l: 50, r: 10, t: 20, b: 35}, uirevision: 1,
                    grid: {rows: 2, columns: 3, pattern: "independent"},
                    annotations: []};
    for (let k = 0; k < 6; ++k) {
      const n = k ? k + 1 : "";
      layout["xaxis" + n] = {title: {text: "F [kN]"}};
      layout["yaxis" + n] = {title: {text: CHANNELS[k] +
                                     (k < 3 ? " [mm]" : " [deg]")}};
    }
    return layout;
  }

  const TIME_CHARTS = [["forces", 3, 0, FORCE, "cmd"],
                       ["translations", 6, 12, CHANNELS.slice(0, 3), "model"],
                       ["angles", 9, 15, CHANNELS.slice(3), "model"]];
  const TRACES = [0, 1, 2, 3, 4, 5];

  // A new run or a snapshot draws anew; otherwise the new bins are
  // appended (extendTraces: no redraw of the whole), the time histories
  // kept to their window.
  function draw() {
    state.dirty = false;
    if (typeof Plotly === "undefined") return;
    if (state.redraw) {
      for (const [id, solid, dashed, names, what] of TIME_CHARTS) {
        Plotly.react(id, timeTraces(solid, dashed, names, what, state.bins),
                     layoutBase, config);
      }
      Plotly.react("loops", loopTraces(state.loop), loopLayout(), config);
      state.redraw = false;
    } else if (state.pending.length) {
      const window = 2 * Math.max(state.bins.length, 1);
      for (const [id, solid, dashed] of TIME_CHARTS) {
        Plotly.extendTraces(id, timePoints(solid, dashed, state.pending),
                            TRACES, window);
      }
      Plotly.extendTraces("loops", loopPoints(state.pending), TRACES,
                          MAX_LOOP_POINTS);
    }
    state.pending = [];
    body.dataset.drawn = String(state.updates);
    const last = state.bins[state.bins.length - 1];
    if (last) body.dataset.lastValues = JSON.stringify(last[4].slice(0, 12));
  }
  function scheduleDraw() {
    if (state.dirty) return;
    state.dirty = true;
    setTimeout(draw, 250);
  }

  function addBins(bins) {
    for (const b of bins) {
      state.bins.push(b);
      state.loop.push(b);
      state.pending.push(b);
    }
    const from = state.bins.length ?
        state.bins[state.bins.length - 1][1] - WINDOW_S : 0;
    let drop = 0;
    while (drop < state.bins.length && state.bins[drop][1] < from) ++drop;
    if (drop) state.bins.splice(0, drop);
    if (state.loop.length > MAX_LOOP_POINTS) {
      state.loop.splice(0, state.loop.length - MAX_LOOP_POINTS);
    }
    state.updates += 1;
    body.dataset.updates = String(state.updates);
    scheduleDraw();
  }

  function showRun(run) {
    state.run = run;
    state.bins = [];
    state.loop = [];
    state.pending = [];
    state.redraw = true;
    for (const key of Object.keys(peaks)) delete peaks[key];
    $("trip").style.display = "none";
    delete body.dataset.trip;
    if (!run) return;
    text("rig", run.rig + (run.real_time || run.rig.includes("virtual clock") ?
                           "" : " (virtual clock)"));
    text("run", run.log_dir || "-");
    body.dataset.run = run.log_dir || "";
    const t = $("excitation");
    t.replaceChildren();
    const e = run.excitation;
    for (const [k, v] of [["direction phi", fmt(e.phi_deg, 1) + " deg"],
                          ["height z_a", fmt(e.z_a_m * 1e3, 0) + " mm"],
                          ["Fmax", fmt(e.fmax_n * 1e-3, 2) + " kN"],
                          ["ramp tf", fmt(e.tf_s, 2) + " s"],
                          ["whole run", fmt(run.duration_s, 2) + " s"]]) {
      const row = t.insertRow();
      cell(row, k);
      cell(row, v, "value");
    }
    scheduleDraw();
  }

  // The highest share of each limit this run, marked on its bar.
  const peaks = {};

  function bar(label, fraction) {
    const row = document.createElement("div");
    row.className = "bar-row";
    const name = document.createElement("span");
    name.textContent = label;
    const outer = document.createElement("div");
    outer.className = "bar";
    const inner = document.createElement("div");
    const f = fraction === null || !isFinite(fraction) ? 1 : fraction;
    inner.style.width = Math.min(100, 100 * f).toFixed(1) + "%";
    if (f >= 0.9) inner.className = "red";
    else if (f >= 0.7) inner.className = "amber";
    peaks[label] = Math.max(peaks[label] || 0, f);
    const peak = document.createElement("span");
    peak.className = "peak";
    peak.style.left = Math.min(100, 100 * peaks[label]).toFixed(1) + "%";
    peak.title = "peak this run " + Math.round(100 * peaks[label]) + " %";
    if (peaks[label] < 0.005) peak.style.display = "none";
    const value = document.createElement("span");
    value.className = "value";
    value.textContent = fraction === null ? "NaN" :
        Math.round(100 * fraction) + " %";
    outer.append(inner, peak);
    row.append(name, outer, value);
    return row;
  }

  function wakeup(us) {
    return state.run && !state.run.real_time ? "- (virtual clock)" :
        fmt(us, 1) + " us";
  }

  function showStatus(s) {
    if (!s) return;
    text("phase", s.phase);
    text("time", fmt(s.t_s, 2) + " s" + (state.run ? " / " +
         fmt(state.run.duration_s, 2) + " s" : ""));
    text("safety", s.safety);
    text("owner", s.owner);
    body.dataset.phase = s.phase;
    // Every phase the page showed, in order: a slow reader sees them all.
    const shown = (body.dataset.phasesShown || "").split(" ").filter(Boolean);
    if (shown[shown.length - 1] !== s.phase) shown.push(s.phase);
    body.dataset.phasesShown = shown.join(" ");
    body.dataset.t = String(s.t_s);
    body.dataset.safety = s.safety;
    const m = s.margins;
    const rows = [];
    FORCE.forEach((n, k) => rows.push(bar("force " + n, m.force[k])));
    FORCE.forEach((n, k) => rows.push(bar("force rate " + n,
                                          m.force_rate[k])));
    CHANNELS.forEach((n, k) => rows.push(bar((k < 3 ? "travel " :
                                              "angle ") + n, m.limits[k])));
    CHANNELS.forEach((n, k) => rows.push(bar("model error " + n,
                                             m.error_detector[k])));
    FORCE.forEach((n, k) => rows.push(bar("tracking " + n,
                                          m.force_tracking[k])));
    rows.push(bar("watchdog", m.watchdog));
    $("margins").replaceChildren(...rows);
    const t = $("timing");
    t.replaceChildren();
    const tm = s.timing;
    for (const [k, v] of [["cycles", tm.cycles], ["overruns", tm.overruns],
                          ["skipped cycles", tm.skipped_cycles],
                          ["wake-up p99", wakeup(tm.wakeup_p99_us)],
                          ["wake-up max", wakeup(tm.wakeup_max_us)]]) {
      const row = t.insertRow();
      cell(row, k);
      cell(row, String(v), "value");
    }
  }

  function showTrip(trip) {
    if (!trip) return;
    const banner = $("trip");
    const stop = trip.cause === "signal";
    banner.textContent = (stop ? "STOPPED by the operator: " : "TRIPPED: ") +
        trip.message;
    banner.className = stop ? "stop" : "";
    banner.style.display = "block";
    body.dataset.trip = trip.cause;
    body.dataset.tripSeenAt = String(trip.seen_at_ms);
    body.dataset.tripShownAt = String(Date.now());
  }

  function showRunEnd(end) {
    if (!end) return;
    text("phase", end.completed ? "completed" : "ended");
    body.dataset.runEnd = end.completed ? "completed" : end.outcome;
  }

  function showStage(stage) {
    if (stage === null) return;
    $("campaign").style.display = "block";
    text("stage", stage);
  }

  function estimateText(p) {
    const n = p.unit === "N/m" ? 1e-3 : 1;
    const unit = p.unit === "N/m" ? "N/mm" : p.unit;
    // No interval where the estimate gives none: not identifiable, or its
    // bounds not finite (null).
    const given = p.ci95 && p.identifiable !== false && p.ci95[0] !== null &&
        p.ci95[1] !== null;
    const half = given ? 0.5 * (p.ci95[1] - p.ci95[0]) * n : null;
    return p.name + " " + fmt(p.value * n, 2) +
        (half === null ? " (no interval)" : " ± " + fmt(half, 2)) + " " + unit;
  }

  function addIteration(it) {
    $("campaign").style.display = "block";
    const table = $("iterations");
    if (!table.rows.length) {
      const head = table.insertRow();
      for (const h of ["iteration", "experiment", "model",
                       "estimates (± 95 %)", "checks", "next"]) {
        const th = document.createElement("th");
        th.textContent = h;
        head.appendChild(th);
      }
    }
    const row = table.insertRow();
    cell(row, String(it.iteration));
    cell(row, "phi " + fmt(it.experiment.phi_deg, 1) + " deg, z_a " +
         fmt(it.experiment.z_a * 1e3, 0) + " mm");
    cell(row, it.model);
    const est = cell(row, "");
    for (const p of (it.parameters || []).concat(it.effect_parameters || [])) {
      const line = document.createElement("div");
      line.textContent = estimateText(p);
      est.appendChild(line);
    }
    const checks = it.check || "ok";
    cell(row, checks, checks === "ok" ? "ok" : "bad");
    const next = it.next_design ? "design phi " +
        fmt(it.next_design.phi_deg, 1) + " deg, z_a " +
        fmt(it.next_design.z_a * 1e3, 0) + " mm" : "";
    const action = it.diagnosis && it.diagnosis.action ?
        it.diagnosis.action + " (" + it.diagnosis.verdict + ")" : "";
    cell(row, [action, next].filter(Boolean).join("; "));
    state.iterations += 1;
    body.dataset.iterations = String(state.iterations);
  }

  // A path on the rig PC, as text: a page served over http may not link
  // to a file, and the operator's browser may be on another machine.
  function showReport(path) {
    if (!path) return;
    text("report", "report written: " + path);
    body.dataset.report = path;
  }

  function addNote(line) {
    const div = document.createElement("div");
    div.textContent = line;
    $("notes").appendChild(div);
    while ($("notes").children.length > 5) $("notes").firstChild.remove();
  }

  function showEnd(outcome) {
    if (outcome === null) return;
    const div = $("ended");
    div.textContent = "kcrig has ended: " + outcome;
    div.style.display = "block";
    body.dataset.ended = outcome;
    $("stop").disabled = true;
  }

  function snapshot(s) {
    if (s.title && s.title.command) {
      text("title", s.title.command);
      document.title = s.title.command + " - kcrig console";
    }
    showRun(s.run);
    if (s.history && s.history.length) addBins(s.history);
    showStatus(s.status);
    showTrip(s.trip);
    showRunEnd(s.run_end);
    showStage(s.stage);
    $("iterations").replaceChildren();
    state.iterations = 0;
    for (const it of s.iterations) addIteration(it);
    showReport(s.report);
    $("notes").replaceChildren();
    for (const n of s.notes) addNote(n);
    showEnd(s.end);
  }

  const handlers = {
    snapshot, run: showRun, bins: addBins, status: showStatus,
    trip: showTrip, run_end: showRunEnd, stage: showStage,
    iteration: addIteration, report: showReport, note: addNote, end: showEnd,
    title: (t) => { text("title", t.command); },
  };

  function connect() {
    const source = new EventSource("events?token=" +
                                   encodeURIComponent(token));
    for (const [name, handle] of Object.entries(handlers)) {
      source.addEventListener(name, (event) => {
        try {
          handle(JSON.parse(event.data));
        } catch (error) {
          body.dataset.error = String(error);
        }
      });
    }
    source.onopen = () => {
      $("connection").className = "field";
      $("connection").lastElementChild.textContent = "live";
      body.dataset.connected = String(Date.now());
    };
    source.onerror = () => {
      $("connection").className = "field lost";
      // Closed for good: refused (a ninth viewer) or kcrig has gone.
      const closed = source.readyState === EventSource.CLOSED;
      $("connection").lastElementChild.textContent =
          body.dataset.ended ? "closed" :
          closed ? "refused or gone (eight viewers at most)" : "reconnecting";
      if (body.dataset.ended) source.close();
    };
  }

  $("stop").addEventListener("click", async () => {
    $("stop").disabled = true;
    text("stop-state", "stopping ...");
    try {
      const reply = await fetch("stop", {
        method: "POST", headers: {"X-Kcrig-Token": token}});
      text("stop-state", reply.ok ? "stop sent: the rig ramps down" :
           "refused (" + reply.status + ")");
      if (!reply.ok) $("stop").disabled = false;
    } catch (error) {
      text("stop-state", "could not reach kcrig: " + error);
      $("stop").disabled = false;
    }
  });

  connect();
})();
