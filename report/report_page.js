// Builds the report's figures from the inlined data with plotly.js, then
// records in #kcrig-status how many figures were created and how many
// rendered (an SVG with drawn traces), and the errors seen.
(function () {
  'use strict';
  var data = JSON.parse(document.getElementById('kcrig-data').textContent);
  var content = document.getElementById('content');
  var nav = document.getElementById('nav');
  var pending = [];
  var created = 0;
  var config = {responsive: true, displaylogo: false};
  var palette = ['#1f77b4', '#d62728', '#2ca02c', '#ff7f0e', '#9467bd',
                 '#8c564b', '#e377c2', '#7f7f7f'];

  function el(tag, attrs, text) {
    var e = document.createElement(tag);
    for (var k in attrs || {}) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function section(id, title) {
    var s = el('section', {id: id});
    s.appendChild(el('h2', {}, title));
    content.appendChild(s);
    var a = el('a', {href: '#' + id}, title);
    nav.appendChild(a);
    return s;
  }
  // A section that fails to build is recorded and the others still drawn.
  function guarded(name, build) {
    try {
      build();
    } catch (error) {
      window.kcrigErrors.push(name + ': ' + String(error));
    }
  }
  function note(parent, text) { parent.appendChild(el('p', {class: 'note'}, text)); }
  // Plotly draws a subset of HTML (links, styles, line breaks) in every text
  // of a figure; strings that come from the input files are text, never
  // markup: escaped here, once, for every figure (plotly shows the entities
  // as the characters).
  function plain(value) {
    if (typeof value === 'string') {
      return value.replace(/&/g, '&amp;').replace(/</g, '&lt;')
          .replace(/>/g, '&gt;');
    }
    if (Array.isArray(value)) return value.map(plain);
    if (value !== null && typeof value === 'object') {
      var out = {};
      for (var k in value) out[k] = plain(value[k]);
      return out;
    }
    return value;
  }
  function figure(parent, traces, layout, height) {
    traces = plain(traces);
    layout = plain(layout);
    var div = el('div', {class: 'figure'});
    div.style.height = (height || 420) + 'px';
    parent.appendChild(div);
    created += 1;
    layout.margin = layout.margin || {l: 70, r: 30, t: 50, b: 50};
    layout.font = {family: 'DejaVu Sans, Arial, sans-serif', size: 12};
    pending.push(Plotly.newPlot(div, traces, layout, config).then(function () {
      return div;
    }));
    return div;
  }
  function fmt(v, digits) {
    return (v === null || v === undefined) ? 'n/a' : Number(v).toPrecision(digits || 3);
  }
  // Axis names of subplot n (1-based) in plotly's convention.
  function ax(n) { return n === 1 ? '' : String(n); }

  var meta = document.getElementById('meta');
  meta.textContent = 'from ' + data.from + ' \u2014 generated ' + data.generated;

  // Measured vs model and residual, six channels, for one log.
  function histories(parent, h, title, extra) {
    var traces = [];
    var layout = {title: {text: title, x: 0, xanchor: 'left', y: 0.99},
                  showlegend: true, height: 1100,
                  margin: {l: 70, r: 30, t: 90, b: 50},
                  grid: {rows: 6, columns: 2, pattern: 'independent',
                         roworder: 'top to bottom'},
                  legend: {orientation: 'h', x: 1, xanchor: 'right', y: 1.05}};
    h.channels.forEach(function (c, k) {
      var left = 2 * k + 1, right = 2 * k + 2;
      var first = k === 0;
      traces.push({x: h.t, y: c.measured, name: 'measured', legendgroup: 'm',
                   showlegend: first, line: {color: '#444', width: 1},
                   xaxis: 'x' + ax(left), yaxis: 'y' + ax(left)});
      traces.push({x: h.t, y: c.model, name: extra ? 'nominal model' : 'model',
                   legendgroup: 'p', showlegend: first,
                   line: {color: palette[0], width: 1.5},
                   xaxis: 'x' + ax(left), yaxis: 'y' + ax(left)});
      if (extra) {
        traces.push({x: h.t, y: c.attributed, name: 'with ' + extra,
                     legendgroup: 'a', showlegend: first,
                     line: {color: palette[1], width: 1.5, dash: 'dash'},
                     xaxis: 'x' + ax(left), yaxis: 'y' + ax(left)});
      }
      traces.push({x: h.t, y: c.residual,
                   name: extra ? 'residual, nominal' : 'residual',
                   legendgroup: 'r', showlegend: first,
                   line: {color: palette[0], width: 1},
                   xaxis: 'x' + ax(right), yaxis: 'y' + ax(right)});
      if (extra) {
        traces.push({x: h.t, y: c.attributed_residual,
                     name: 'residual, with ' + extra, legendgroup: 'ar',
                     showlegend: first, line: {color: palette[1], width: 1},
                     xaxis: 'x' + ax(right), yaxis: 'y' + ax(right)});
      }
      // +-2 sigma of the sensor: what a residual of pure noise stays within.
      var t0 = h.t[0], t1 = h.t[h.t.length - 1];
      traces.push({x: [t0, t1, null, t0, t1],
                   y: [2 * c.sigma, 2 * c.sigma, null, -2 * c.sigma, -2 * c.sigma],
                   name: '\u00b12\u03c3 sensor noise', legendgroup: 's',
                   showlegend: first, mode: 'lines',
                   line: {color: '#2ca02c', width: 1, dash: 'dot'},
                   xaxis: 'x' + ax(right), yaxis: 'y' + ax(right)});
      layout['yaxis' + ax(left)] = {title: {text: c.name + ' [' + c.unit + ']'}};
      layout['yaxis' + ax(right)] = {
        title: {text: 'residual [' + c.unit + ']'}};
      if (k === 5) {
        layout['xaxis' + ax(left)] = {title: {text: 't [s]'}};
        layout['xaxis' + ax(right)] = {title: {text: 't [s]'}};
      }
    });
    figure(parent, traces, layout, 1100);
    var rms = h.channels.map(function (c) {
      var after = extra ? ' \u2192 ' + fmt(c.attributed_rms, 3) : '';
      return c.name + ' ' + fmt(c.rms, 3) + after + ' ' + c.unit;
    });
    note(parent, 'residual RMS: ' + rms.join(', '));
  }

  // One screen first: what the work concluded (the final estimates, the
  // checks and the adopted model, the diagnoses' verdicts, the K&C sheet's
  // agreement, the loop's budget), before the figures that show why.
  function diagnosisLine(d) {
    return d.verdict + (d.model !== d.verdict && d.components.length ?
                        ' in ' + d.components.join(' and ') : '') +
           (d.confidence ? ' (confidence ' + d.confidence + ')' : '') +
           ' \u2014 ' + d.reason;
  }
  function campaignSummary(s, c) {
    var n = c.iterations.length;
    s.appendChild(el('div', {class: 'verdict'}, 'Campaign: ' + n +
        ' iteration' + (n === 1 ? '' : 's') + '; final model: ' +
        (c.model === 'nominal' ? 'nominal' : 'nominal + ' + c.model) +
        ' \u2014 ' + (c.check === 'ok' ?
                      'the final estimates pass every check (fit, prediction, ' +
                      'consistency)' :
                      'the final estimates are NOT to be trusted: ' + c.check +
                      (c.adequacy_reason ? ' (' + c.adequacy_reason + ')' : '') +
                      (c.action === 'stopped' ? '; the campaign stopped' : ''))));
    s.appendChild(el('h3', {}, 'Final estimates'));
    var estimates = el('table');
    row(estimates, ['parameter', 'value', '95 % interval', 'unit'], true);
    c.estimates.forEach(function (p) {
      var interval = p.ci95_low === null || p.ci95_high === null ?
                     'not given' : fmt(p.ci95_low, 5) + ' \u2026 ' + fmt(p.ci95_high, 5);
      row(estimates, [p.name, fmt(p.value, 5) + (p.at_bound ? ' (on its bound)' : ''),
                      interval, p.unit]);
    });
    s.appendChild(estimates);
    s.appendChild(el('h3', {}, 'Checks and actions per iteration'));
    var checks = el('table');
    row(checks, ['iteration', 'logs', 'model', 'checks', 'action'], true);
    c.iterations.forEach(function (r) {
      row(checks, [String(r.index), String(r.logs), r.model, r.checks,
                   r.action || '']);
    });
    s.appendChild(checks);
  }
  guarded('summary', function () {
    var c = data.campaign_summary, diagnoses = data.diagnoses || [];
    var timings = data.timings || [];
    if (!c && !diagnoses.length && !data.kc && !timings.length) return;
    var s = section('summary', 'Summary');
    if (c) campaignSummary(s, c);
    var lines = el('ul');
    diagnoses.forEach(function (d) {
      lines.appendChild(el('li', {}, 'Diagnosis (' + d.file + '): ' + diagnosisLine(d)));
    });
    if (data.kc) {
      var differ = data.kc.sheet.differing_channels;
      lines.appendChild(el('li', {}, 'K&C sheet: ' + (differ.length ?
          'model and rig differ on ' + differ.join(', ') :
          'model and rig agree on every channel')));
    }
    timings.forEach(function (t) {
      lines.appendChild(el('li', {}, 'Loop timing (' + t.source + '): ' +
          t.overruns + ' overruns, ' + t.skipped_cycles + ' skipped cycles; budget ' +
          (t.within_budget === null ? 'not checked' :
           (t.within_budget ? 'met' : 'VIOLATED'))));
    });
    if (lines.children.length) s.appendChild(lines);
  });

  guarded('experiments', function () { if (data.experiments) {
    var s = section('experiments', 'Experiments: measured vs model');
    note(s, 'Each experiment against the ' + data.model_label +
         '; residual = measured \u2212 model, with the sensor\u2019s \u00b12\u03c3.');
    data.experiments.forEach(function (h) {
      s.appendChild(el('h3', {}, h.name + ' \u2014 phi ' + fmt(h.phi_deg, 3) +
                               ' deg, z_a ' + fmt(h.z_a, 3) + ' m'));
      histories(s, h, h.name);
    });
  }

  });

  // The K&C sheet: per run the gradients and loop widths, the rig beside
  // the model, their difference coloured by its significance, and the
  // response-vs-force loops; the standard figures; the model's compliance
  // matrix.
  function significance(z) {
    if (z === null || z === undefined) return '';
    var a = Math.abs(z);
    return a > 3 ? '#f4b6b4' : (a > 2 ? '#fbe3a6' : '');
  }
  function row(table, cells, header) {
    var tr = el('tr');
    cells.forEach(function (c) {
      var cell = el(header ? 'th' : 'td', {}, c.text !== undefined ? c.text : c);
      if (c.color) cell.style.background = c.color;
      tr.appendChild(cell);
    });
    table.appendChild(tr);
  }
  function zCell(z) { return {text: fmt(z, 2), color: significance(z)}; }
  function kcRun(s, run, loops, model) {
    s.appendChild(el('h3', {}, run.log + ' \u2014 phi ' + fmt(run.phi_deg, 3) +
                             ' deg, z_a ' + fmt(run.z_a, 3) + ' m'));
    var table = el('table');
    row(table, ['channel', 'gradient', 'rig', '\u00b1 se', model,
                'z', 'loop width', 'rig', '\u00b1 se', model, 'z'], true);
    run.channels.forEach(function (c) {
      var w = c.loop_width;
      row(table, [c.channel, c.gradient.unit, fmt(c.gradient.rig.value, 4),
                  fmt(c.gradient.rig.standard_error, 2),
                  fmt(c.gradient.model.value, 4),
                  zCell(c.gradient.difference_z),
                  w ? w.unit : '\u2014', w ? fmt(w.rig.value, 3) : '',
                  w ? fmt(w.rig.standard_error, 2) : '',
                  w ? fmt(w.model.value, 3) : '',
                  w ? zCell(w.difference_z) : '']);
    });
    s.appendChild(table);
    var traces = [];
    var layout = {title: {text: 'Response against the force along the ramp: ' +
                                run.log, x: 0, xanchor: 'left'},
                  grid: {rows: 2, columns: 3, pattern: 'independent'},
                  showlegend: true,
                  legend: {orientation: 'h', x: 1, xanchor: 'right', y: 1.12}};
    loops.branches.forEach(function (b, bi) {
      run.channels.forEach(function (c, k) {
        var first = k === 0;
        traces.push({x: b.force, y: b.rig[k], mode: 'lines',
                     name: 'rig, ' + b.name, legendgroup: 'r' + bi,
                     showlegend: first,
                     line: {color: bi === 0 ? '#444' : '#999', width: 1},
                     xaxis: 'x' + ax(k + 1), yaxis: 'y' + ax(k + 1)});
        traces.push({x: b.force, y: b.model[k], mode: 'lines',
                     name: model + ', ' + b.name, legendgroup: 'm' + bi,
                     showlegend: first,
                     line: {color: palette[bi === 0 ? 0 : 1], width: 1.5,
                            dash: 'dash'},
                     xaxis: 'x' + ax(k + 1), yaxis: 'y' + ax(k + 1)});
        layout['xaxis' + ax(k + 1)] = {title: {text: 'F [kN]'}};
        layout['yaxis' + ax(k + 1)] = {title: {text: c.channel + ' [' +
            (k < 3 ? 'mm' : 'deg') + ']'}};
      });
    });
    figure(s, traces, layout, 620);
  }
  function kcMatrix(s, title, m) {
    s.appendChild(el('h3', {}, title));
    var table = el('table');
    row(table, [''].concat(m.columns), true);
    m.rows.forEach(function (name, r) {
      row(table, [name].concat(m.matrix[r].map(function (v, c) {
        return fmt(v, 4) + ' ' + m.units[r][c];
      })));
    });
    s.appendChild(table);
  }
  guarded('kc', function () { if (data.kc) {
    var sheet = data.kc.sheet;
    var model = sheet.model + ' model';
    var s = section('kc', 'K&C sheet');
    note(s, 'Compliance gradients against the force along each ramp (' +
         sheet.convention + ' axes: mm/kN, deg/kN) and the loop width at zero ' +
         'force (falling minus rising branch), the rig beside the ' + model +
         ' at the final estimate; z is their difference in combined standard ' +
         'errors, amber beyond 2, red beyond 3.' +
         (sheet.differing_channels.length ?
          ' Channels that differ: ' + sheet.differing_channels.join(', ') + '.' :
          ' Model and rig agree on every channel.'));
    sheet.runs.forEach(function (run, i) {
      kcRun(s, run, data.kc.loops[i], model);
    });
    s.appendChild(el('h3', {}, 'Standard figures'));
    var named = el('table');
    row(named, ['figure', 'at', 'rig', '\u00b1 se', model, 'z',
                'suspension static', 'unit'], true);
    sheet.named_figures.forEach(function (f) {
      row(named, [f.name, f.place, f.rig === null ? '' : fmt(f.rig, 4),
                  f.rig === null ? '' : fmt(f.rig_standard_error, 2),
                  f.model === null ? '' : fmt(f.model, 4),
                  f.difference_z === null ? '' : zCell(f.difference_z),
                  fmt(f.model_static, 4), f.unit]);
    });
    s.appendChild(named);
    note(s, 'Suspension static: the model\u2019s analytic compliance at zero ' +
         'speed, without the rig\u2019s own compliance or dynamics, which the ' +
         'measured figures include.');
    if (sheet.compliance) {
      kcMatrix(s, 'Wheel-centre compliance matrix of the model (force and ' +
               'moment at the wheel centre \u2192 its displacement and the ' +
               'angles)', sheet.compliance.wheel_centre);
    }
  }
  });

  guarded('estimates', function () { if (data.estimates) {
    var e = data.estimates;
    var s2 = section('sensitivity', 'Sensitivities and estimates');
    note(s2, 'log10 diag((J\u1d40J)\u207b\u00b9) per parameter (the paper\u2019s ' +
         'Figs. 4 and 6): lower is better determined. The first iteration is ' +
         'the initial experiment, the later ones add the optimal designs (' +
         (data.criterion || '') + ' criterion).');
    var bars = e.iterations.map(function (label, i) {
      return {type: 'bar', name: i === 0 ? label + ', before design' :
                                          (i === e.iterations.length - 1 ?
                                           label + ', after design' : label),
              x: e.parameters, y: e.log10_diag_inv_jtj[i],
              marker: {color: palette[i % palette.length]}};
    });
    figure(s2, bars, {title: {text: 'Sensitivity: log10 diag((J\u1d40J)\u207b\u00b9)'},
                      barmode: 'group',
                      yaxis: {title: {text: 'log10 diag((J\u1d40J)\u207b\u00b9)'}},
                      legend: {orientation: 'h', y: -0.15}});
    var traces = [];
    var layout = {title: {text: 'Estimates with 95 % intervals per iteration'},
                  showlegend: false,
                  grid: {rows: 1, columns: e.parameters.length,
                         pattern: 'independent'}};
    e.parameters.forEach(function (name, p) {
      var x = [], y = [], up = [], down = [];
      e.iterations.forEach(function (label, i) {
        x.push(i);
        y.push(e.value[i][p]);
        var lo = e.ci95_low[i][p], hi = e.ci95_high[i][p];
        up.push(hi === null ? 0 : hi - e.value[i][p]);
        down.push(lo === null ? 0 : e.value[i][p] - lo);
      });
      traces.push({x: x, y: y, mode: 'markers+lines', name: name,
                   error_y: {type: 'data', symmetric: false, array: up,
                             arrayminus: down},
                   xaxis: 'x' + ax(p + 1), yaxis: 'y' + ax(p + 1),
                   marker: {color: palette[p % palette.length]}});
      layout['xaxis' + ax(p + 1)] = {title: {text: name + ', iteration'},
                                     dtick: 1};
      layout['yaxis' + ax(p + 1)] = {tickformat: '.5r',
                                     title: {text: e.units[p]}};
    });
    figure(s2, traces, layout, 380);
    if (data.initial_states) initialStates(s2, data.initial_states);
  }

  });

  // Where the final fit's model started each log: a rig remembers its last
  // run (a bushing's friction, a structure still creeping).
  function initialStates(s, st) {
    s.appendChild(el('h3', {}, 'Initial state of each log (iteration ' +
                             st.iteration + '\u2019s fit)'));
    note(s, 'The tare\u2019s mean pose, and where the model started: at ' +
         'rest under the first force, from the Dahl (friction) forces the ' +
         'rig kept from its run before, fitted to that tare, and/or from ' +
         'the tare\u2019s first-row pose (a structure still creeping).');
    var table = el('table');
    row(table, ['log', 'start'].concat(st.channels, st.bushings.map(
        function (b) { return 'Dahl ' + b + ' [N]'; })), true);
    st.logs.forEach(function (log) {
      var start = [];
      if (log.dahl_force_N) start.push('Dahl forces');
      if (log.first_row_pose) start.push('first-row pose');
      var none = function () { return null; };
      var tare = log.tare_mean || st.channels.map(none);
      var dahl = log.dahl_force_N || st.bushings.map(none);
      row(table, [log.log, start.length ? start.join(' + ') : 'equilibrium']
          .concat(tare.map(function (v) { return fmt(v, 3); }),
                  dahl.map(function (v) { return fmt(v, 3); })));
    });
    s.appendChild(table);
  }

  guarded('surfaces', function () { if (data.surfaces) {
    var s3 = section('surfaces', 'Criterion surfaces over (phi, z_a)');
    note(s3, 'D and A criteria of the next experiment of each iteration ' +
         'that designed: the objective its optimizer searched, at that ' +
         'iteration\u2019s estimate with the information of its data ' +
         '(est.json) as prior (the paper\u2019s Fig. 5); smaller is better. ' +
         'Markers: the optimizer\u2019s evaluated designs; line: its path; ' +
         'star: the designed experiment, with the criterion there.');
    data.surfaces.forEach(function (surface) {
      var traces = [{type: 'contour', x: surface.phi_deg, y: surface.z_a,
                     z: surface.values, colorscale: 'Viridis', ncontours: 25,
                     colorbar: {title: {text: surface.criterion}},
                     name: surface.criterion}];
      surface.runs.forEach(function (run, i) {
        traces.push({type: 'scatter', mode: 'markers', name: run.optimizer +
                     ' evaluated',
                     x: run.evaluated.map(function (r) { return r[0]; }),
                     y: run.evaluated.map(function (r) { return r[1]; }),
                     marker: {color: '#fff', size: 6,
                              line: {color: palette[i + 1], width: 1.5}}});
        traces.push({type: 'scatter', mode: 'lines+markers', name: run.optimizer +
                     ' path',
                     x: run.path.map(function (r) { return r[0]; }),
                     y: run.path.map(function (r) { return r[1]; }),
                     line: {color: palette[i + 1], width: 2}});
      });
      var best = surface.optimum;
      traces.push({type: 'scatter', mode: 'markers', name: 'designed (' +
                   surface.criterion + ' ' + (best.value === null ? 'n/a' :
                   best.value.toPrecision(6)) + ')', x: [best.phi_deg],
                   y: [best.z_a],
                   marker: {symbol: 'star', size: 16, color: palette[1],
                            line: {color: '#000', width: 1}}});
      figure(s3, traces, {title: {text: surface.criterion + ' criterion, ' +
                                        surface.iteration + ' design'},
                           xaxis: {title: {text: 'phi [deg]'}},
                           yaxis: {title: {text: 'z_a [m]'}},
                           legend: {orientation: 'h', y: -0.2}}, 480);
    });
  }

  });

  guarded('kriging', function () { if (data.kriging) {
    var k = data.kriging;
    var s4 = section('kriging', 'Kriging surrogate refinement');
    note(s4, 'The ' + k.criterion + ' criterion\u2019s kriging surrogate (' +
         k.iteration + ') refitted to the samples it had after each stage ' +
         '(the paper\u2019s Fig. 2); dots: the samples.');
    var traces = [], layout = {grid: {rows: 1, columns: k.panels.length,
                                      pattern: 'independent'},
                               showlegend: false,
                               title: {text: 'Surrogate of the ' + k.criterion +
                                             ' criterion as it was refined'}};
    k.panels.forEach(function (panel, i) {
      var n = i + 1;
      traces.push({type: 'contour', x: panel.phi_deg, y: panel.z_a,
                   z: panel.values, colorscale: 'Viridis', ncontours: 20,
                   showscale: i === k.panels.length - 1,
                   xaxis: 'x' + ax(n), yaxis: 'y' + ax(n)});
      traces.push({type: 'scatter', mode: 'markers',
                   x: panel.points.map(function (p) { return p[0]; }),
                   y: panel.points.map(function (p) { return p[1]; }),
                   marker: {color: '#fff', size: 6,
                            line: {color: '#000', width: 1}},
                   xaxis: 'x' + ax(n), yaxis: 'y' + ax(n)});
      layout['xaxis' + ax(n)] = {title: {text: 'phi [deg] \u2014 ' + panel.label}};
      layout['yaxis' + ax(n)] = {title: {text: n === 1 ? 'z_a [m]' : ''}};
    });
    figure(s4, traces, layout, 420);
  }

  });

  guarded('isolability', function () { if (data.isolability) {
    var iso = data.isolability;
    var s6 = section('isolability', 'Which faults the experiments tell apart');
    note(s6, 'Iteration ' + iso.iteration + "'s logs: the share of each " +
         "fault's signature (row) that the rival (column), refitted with " +
         'the stiffnesses, cannot reproduce. A pair is told apart when ' +
         'each leaves at least ' + Math.round(100 * iso.min_share_left) +
         ' % of the other\'s; white: an effect these experiments do not see.');
    // The diagonal (a fault against itself) blank.
    var percent = iso.left.map(function (row, i) {
      return row.map(function (v, j) {
        return v === null || i === j ? null : 100 * v;
      });
    });
    figure(s6, [{type: 'heatmap', x: iso.candidates, y: iso.candidates,
                 z: percent, zmin: 0, zmax: 100,
                 colorscale: [[0, '#b2182b'],
                              [iso.min_share_left, '#fddbc7'],
                              [iso.min_share_left + 0.001, '#d1e5f0'],
                              [1, '#2166ac']],
                 colorbar: {title: {text: '% left'}},
                 hovertemplate: 'fault %{y}<br>rival %{x}<br>' +
                                '%{z:.0f} % of its signature left<extra></extra>'}],
           {title: {text: 'Isolability: % of the fault\'s signature the ' +
                          'rival leaves (red: cannot tell apart)'},
            xaxis: {tickangle: -60, automargin: true, tickfont: {size: 9}},
            yaxis: {autorange: 'reversed', automargin: true,
                    tickfont: {size: 9}}},
           Math.max(420, 16 * iso.candidates.length + 260));
  }

  });

  guarded('diagnosis', function () { if (data.diagnoses && data.diagnoses.length) {
    var s5 = section('diagnosis', 'Sim-to-real gap diagnosis');
    data.diagnoses.forEach(function (d) {
      s5.appendChild(el('h3', {}, d.file));
      s5.appendChild(el('div', {class: 'verdict'}, 'verdict: ' + diagnosisLine(d)));
      // Each cell's value written on it (plotly 2.6 heatmaps have no
      // texttemplate).
      var cells = [];
      d.energy.forEach(function (row, r) {
        row.forEach(function (v, c) {
          if (v === null) return;
          cells.push({x: d.channels[c], y: d.regimes[r], text: fmt(v, 3),
                      showarrow: false, font: {color: v > 10 ? '#fff' : '#000'}});
        });
      });
      figure(s5, [{type: 'heatmap', x: d.channels, y: d.regimes, z: d.energy,
                   colorscale: 'YlOrRd', reversescale: true, zmin: 1,
                   colorbar: {title: {text: 'score'}}}],
             {title: {text: 'Residual energy by channel \u00d7 load regime ' +
                            '(mean (r/\u03c3)\u00b2; 1 = noise)'},
              yaxis: {autorange: 'reversed'}, annotations: cells}, 420);
      if (d.ranking.length) {
        var models = d.ranking.map(function (c) { return c.model; });
        var scores = d.ranking.map(function (c) { return c.score; });
        var closed = d.ranking.map(function (c) {
          return c.gap_closed === null ? '' :
                 Math.round(100 * c.gap_closed) + ' % closed';
        });
        models.push('nominal');
        scores.push(d.nominal_score);
        closed.push('');
        figure(s5, [{type: 'bar', orientation: 'h', y: models, x: scores,
                     text: closed, textposition: 'auto',
                     marker: {color: models.map(function (m) {
                       return m === d.model ? palette[1] :
                              (m === 'nominal' ? '#999' : palette[0]);
                     })}}],
               {title: {text: 'Candidates ranked by their ' + d.scoring +
                              ' score (1 = noise floor)'},
                xaxis: {type: 'log', title: {text: 'score'}},
                yaxis: {autorange: 'reversed', automargin: true},
                shapes: [{type: 'line', x0: 1, x1: 1, yref: 'paper', y0: 0,
                          y1: 1, line: {color: '#2ca02c', dash: 'dot'}}]},
               Math.max(300, 40 * models.length + 120));
      }
      if (d.overlay) {
        var label = d.overlay.attributed ? d.overlay.attributed_model :
                    d.overlay.attributed_model + ' (best candidate, not attributed)';
        histories(s5, d.overlay, 'On the ' + d.overlay_on + ' ' + d.overlay.log +
                  ': nominal vs with ' + label, label);
      } else if (d.overlay_missing) {
        note(s5, 'No before/after overlay: ' + d.overlay_missing);
      } else {
        note(s5, 'No before/after overlay: no candidate was fitted.');
      }
    });
  }

  });

  guarded('timing', function () { if (data.timings && data.timings.length) {
    var s6 = section('timing', 'Loop timing');
    data.timings.forEach(function (t) {
      var phases = ['wakeup', 'compute', 'cycle'].filter(function (p) {
        return t.histograms[p];
      });
      var traces = [], shapes = [];
      var layout = {grid: {rows: 1, columns: phases.length,
                           pattern: 'independent'},
                    showlegend: false,
                    title: {text: t.source + ': period ' + fmt(t.period_us, 4) +
                                  ' \u00b5s, ' + t.cycles + ' cycles, ' +
                                  t.overruns + ' overruns, ' + t.skipped_cycles +
                                  ' skipped; budget ' +
                                  (t.within_budget === null ? 'not checked' :
                                   (t.within_budget ? 'met' : 'VIOLATED'))}};
      phases.forEach(function (p, i) {
        var n = i + 1, h = t.histograms[p];
        traces.push({type: 'bar', x: h.us, y: h.count, name: p,
                     marker: {color: palette[i]},
                     xaxis: 'x' + ax(n), yaxis: 'y' + ax(n)});
        layout['xaxis' + ax(n)] = {type: 'log', title: {text: p + ' [\u00b5s] (p99 ' +
                                                 fmt(h.p99_us, 3) + ', max ' +
                                                 fmt(h.max_us, 3) + ')'}};
        layout['yaxis' + ax(n)] = {type: 'log', title: {text: n === 1 ? 'cycles' : ''}};
        if (t.budget_us[p] !== undefined) {
          shapes.push({type: 'line', xref: 'x' + ax(n), yref: 'paper',
                       x0: t.budget_us[p], x1: t.budget_us[p], y0: 0, y1: 1,
                       line: {color: '#d62728', width: 2, dash: 'dash'}});
          var low = Math.max(0.1, 0.8 * (h.us[0] || 1));
          layout['xaxis' + ax(n)].range = [
              Math.log10(low),
              Math.log10(1.25 * Math.max(t.budget_us[p], h.max_us || 0))];
        }
      });
      layout.shapes = shapes;
      figure(s6, traces, layout, 380);
      note(s6, 'Dashed red: the budget (wake-up p99, compute and cycle ' +
           'p99.9 as fractions of the period, from rig.yaml).' +
           ((t.violations || []).length ?
            ' Violations: ' + t.violations.join('; ') : ''));
    });
  }

  });

  guarded('validation', function () { if (data.validations && data.validations.length) {
    var s7 = section('validation', 'Validation: how well kcrig diagnoses this configuration');
    data.validations.forEach(function (v) {
      var f = v.figures;
      function tally(t, hits) { return t[hits] + '/' + t.total; }
      s7.appendChild(el('h3', {}, v.source + ' (seed ' + v.seed + ', ' +
                        v.cases.length + ' cases)'));
      s7.appendChild(el('div', {class: 'verdict'},
          'library effects > 3\u03c3 named: ' +
          tally(f.library_effects_beyond_3_sigma, 'correct') +
          '; clean logs called none: ' + tally(f.clean, 'none') +
          '; wrong parameters > 3\u03c3 named: ' +
          tally(f.wrong_parameters_beyond_3_sigma, 'named') +
          '; gap closed \u2265 80 % when correct: ' +
          tally(f.gap_closed_80_percent_when_correct, 'closed') +
          '; confident wrong answers: ' + f.confident_wrong));
      // A count matrix as a heat map with each count written on its cell.
      function counts(title, m) {
        var cells = [], most = 1;
        m.counts.forEach(function (row) { most = Math.max.apply(null, [most].concat(row)); });
        m.counts.forEach(function (row, r) {
          row.forEach(function (n, c) {
            if (n) cells.push({x: m.columns[c], y: m.rows[r], text: String(n),
                               showarrow: false,
                               font: {color: n > most / 2 ? '#fff' : '#000'}});
          });
        });
        figure(s7, [{type: 'heatmap', x: m.columns, y: m.rows, z: m.counts,
                     colorscale: 'Blues', reversescale: true, zmin: 0,
                     colorbar: {title: {text: 'cases'}}}],
               {title: {text: title}, annotations: cells,
                yaxis: {autorange: 'reversed', automargin: true},
                xaxis: {automargin: true}},
               Math.max(320, 40 * m.rows.length + 160));
      }
      counts('Confusion matrix (rows: truth, columns: verdict)', v.confusion);
      if (v.places.rows.length) {
        counts('Bushing effects: where they act (rows) and where kcrig ' +
               'placed them (columns)', v.places);
      }
      var curves = [];
      Object.keys(v.power).forEach(function (truth, i) {
        var bins = v.power[truth].bins.filter(function (b) { return b.cases; });
        curves.push({type: 'scatter', mode: 'lines+markers', name: truth,
                     marker: {color: palette[i % palette.length]},
                     x: bins.map(function (b) {
                       return b.to_sigma === null ? 2 * b.from_sigma :
                              Math.max(0.5, Math.sqrt(Math.max(b.from_sigma, 0.25) *
                                                      b.to_sigma));
                     }),
                     y: bins.map(function (b) { return 100 * b.detected / b.cases; }),
                     text: bins.map(function (b) {
                       return '[' + b.from_sigma + ', ' +
                              (b.to_sigma === null ? '\u221e' : b.to_sigma) +
                              ') \u03c3: ' + b.detected + '/' + b.cases;
                     }),
                     hoverinfo: 'name+text'});
      });
      if (curves.length) figure(s7, curves,
             {title: {text: 'Power curve: detection rate against effect size'},
              xaxis: {type: 'log', title: {text: 'effect size [noise units ' +
                                               '\u03c3, bin centre]'}},
              yaxis: {title: {text: 'named correctly [%]'}, range: [-5, 105]},
              shapes: [{type: 'line', x0: 3, x1: 3, yref: 'paper', y0: 0, y1: 1,
                        line: {color: '#999', dash: 'dot'}}]}, 420);
      var outcome = [['correct', '#2ca02c'], ['wrong', '#ff7f0e'],
                     ['confident wrong', '#d62728']];
      figure(s7, outcome.map(function (o) {
        var mine = v.cases.filter(function (c) {
          var kind = c.correct ? 'correct' :
                     (c.confident_wrong ? 'confident wrong' : 'wrong');
          return kind === o[0];
        });
        return {type: 'scatter', mode: 'markers', name: o[0],
                marker: {color: o[1], size: 9},
                x: mine.map(function (c) { return Math.max(c.size_sigma, 0.05); }),
                y: mine.map(function (c) { return c.truth; }),
                text: mine.map(function (c) { return 'verdict ' + c.verdict; }),
                hoverinfo: 'x+y+text'};
      }), {title: {text: 'Every case: its size and what kcrig said (clean ' +
                         'cases at the left edge)'},
           xaxis: {type: 'log', title: {text: 'effect size [\u03c3]'}},
           yaxis: {automargin: true}},
             Math.max(320, 40 * v.confusion.rows.length + 160));
    });
  }

  });

  // A figure rendered when plotly drew its SVG and at least one trace.
  var status = document.getElementById('kcrig-status');
  Promise.all(pending).then(function (divs) {
    var rendered = divs.filter(function (div) {
      var svg = div.querySelector('svg.main-svg');
      var drawn = div.querySelectorAll(
          '.trace, .heatmaplayer image, .contourlayer path, .barlayer path');
      return svg !== null && drawn.length > 0 &&
             div.getBoundingClientRect().height > 0;
    }).length;
    status.setAttribute('data-state', 'done');
    status.setAttribute('data-figures', String(created));
    status.setAttribute('data-rendered', String(rendered));
    status.setAttribute('data-expected', String(data.expected_figures));
    status.setAttribute('data-errors', JSON.stringify(window.kcrigErrors));
    status.textContent = 'kcrig-status figures=' + created + ' rendered=' +
                         rendered + ' errors=' + window.kcrigErrors.length;
  }, function (error) {
    window.kcrigErrors.push(String(error));
    status.setAttribute('data-state', 'failed');
    status.setAttribute('data-errors', JSON.stringify(window.kcrigErrors));
  });
})();
