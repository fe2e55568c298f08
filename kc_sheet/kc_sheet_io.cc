#include "kc_sheet/kc_sheet_io.h"

#include <cmath>
#include <cstdio>

#include "base/json_writer.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

using Json = nlohmann::ordered_json;

// Per kN of a gradient, and its unit: mm/kN, deg/kN.
double PerKilonewton(int c, double si) {
  return ChannelDisplayValue(c, si) * 1e3;
}
std::string GradientUnit(int c) {
  return std::string(ChannelDisplayUnit(c)) + "/kN";
}
// A loop's area in kN mm (= J) or kN deg.
double AreaDisplay(int c, double si) {
  return ChannelDisplayValue(c, si) * 1e-3;
}
std::string AreaUnit(int c) {
  return std::string("kN ") + ChannelDisplayUnit(c);
}

const char* ConventionName(SignConvention convention) {
  return convention == SignConvention::kSae ? "SAE J670" : "ISO 8855";
}

Json FigureJson(const Figure& f, double scale) {
  return {
      {"value", FiniteOrNull(f.value * scale)},
      {"standard_error", FiniteOrNull(f.standard_error * scale)},
      {"noise_standard_error", FiniteOrNull(f.noise_standard_error * scale)}};
}

Json LineJson(const LineFit& line, int c) {
  if (line.samples == 0) return nullptr;
  return {
      {"gradient", FiniteOrNull(PerKilonewton(c, line.slope))},
      {"standard_error", FiniteOrNull(PerKilonewton(c, line.standard_error))},
      {"noise_standard_error",
       FiniteOrNull(PerKilonewton(c, line.noise_standard_error))},
      {"intercept", FiniteOrNull(ChannelDisplayValue(c, line.intercept))},
      {"residual_rms", FiniteOrNull(ChannelDisplayValue(c, line.residual_rms))},
      {"samples", line.samples}};
}

Json ComparisonJson(const Comparison& c) {
  return {{"difference_z", FiniteOrNull(c.z)}, {"differs", c.differs}};
}

Json ChannelJson(const KcSheet& sheet, const RunSheet& run, int c) {
  const double per_kn = PerKilonewton(c, 1.0);
  const double display = ChannelDisplayValue(c, 1.0);
  Json channel = {{"channel", kChannelNames[c]}};
  Json gradient = {{"unit", GradientUnit(c)},
                   {"rig", FigureJson(run.rig[c].gradient, per_kn)}};
  Json width = {{"unit", ChannelDisplayUnit(c)},
                {"rig", FigureJson(run.rig[c].loop_width, display)}};
  Json area = {{"unit", AreaUnit(c)},
               {"rig", FiniteOrNull(AreaDisplay(c, run.rig[c].loop_area))}};
  if (sheet.has_model) {
    gradient["model"] = {
        {"value", FiniteOrNull(run.model[c].gradient.value * per_kn)},
        {"standard_error", FiniteOrNull(run.model_gradient_se[c] * per_kn)}};
    gradient["model_static"] = FiniteOrNull(run.static_gradient[c] * per_kn);
    gradient.update(ComparisonJson(run.gradient_difference[c]));
    width["model"] = {
        {"value", FiniteOrNull(run.model[c].loop_width.value * display)},
        {"standard_error", FiniteOrNull(run.model_loop_width_se[c] * display)}};
    width.update(ComparisonJson(run.loop_width_difference[c]));
    area["model"] = FiniteOrNull(AreaDisplay(c, run.model[c].loop_area));
  }
  channel["gradient"] = gradient;
  channel["rising"] = LineJson(run.rig[c].rising, c);
  channel["falling"] = LineJson(run.rig[c].falling, c);
  if (sheet.has_model) {
    channel["model_rising"] = LineJson(run.model[c].rising, c);
    channel["model_falling"] = LineJson(run.model[c].falling, c);
  }
  channel["loop_width"] = run.has_falling ? width : Json(nullptr);
  channel["loop_area"] = run.has_falling ? area : Json(nullptr);
  return channel;
}

Json MatrixJson(const Mat6<double>& m) {
  static const char* kLoads[6] = {"Fx", "Fy", "Fz", "Mx", "My", "Mz"};
  Json rows = Json::array(), units = Json::array();
  for (int c = 0; c < 6; ++c) {
    Json row = Json::array(), unit_row = Json::array();
    for (int k = 0; k < 6; ++k) {
      // Per kN, or per kN m.
      row.push_back(FiniteOrNull(ChannelDisplayValue(c, m(c, k)) * 1e3));
      unit_row.push_back(std::string(ChannelDisplayUnit(c)) +
                         (k < 3 ? "/kN" : "/kN m"));
    }
    rows.push_back(row);
    units.push_back(unit_row);
  }
  Json loads = Json::array();
  for (const char* l : kLoads) loads.push_back(l);
  Json channels = Json::array();
  for (const char* c : kChannelNames) channels.push_back(c);
  return {{"rows", channels},
          {"columns", loads},
          {"units", units},
          {"matrix", rows}};
}

}  // namespace

std::string KcSheetToJson(const KcSheet& sheet) {
  Json doc = {{"format", "kcrig kc 1"},
              {"convention", ConventionName(sheet.convention)},
              {"model", sheet.has_model ? Json(sheet.model_name) : Json()}};
  Json runs = Json::array();
  for (const RunSheet& run : sheet.runs) {
    Json channels = Json::array();
    for (int c = 0; c < 6; ++c) channels.push_back(ChannelJson(sheet, run, c));
    runs.push_back({{"log", run.source},
                    {"phi_deg", FiniteOrNull(run.phi / kDegree)},
                    {"z_a", FiniteOrNull(run.z_a)},
                    {"fmax_kN", FiniteOrNull(run.fmax * 1e-3)},
                    {"falling_branch", run.has_falling},
                    {"channels", channels}});
  }
  doc["runs"] = runs;
  Json components = Json::array();
  for (const ComponentSheet& cs : sheet.components) {
    Json gradients = Json::array();
    for (int c = 0; c < 6; ++c) {
      for (int k = 0; k < 2; ++k) {
        const double per_kn = PerKilonewton(c, 1.0);
        Json g = {
            {"channel", kChannelNames[c]},
            {"force", k == 0 ? "Fx" : "Fy"},
            {"unit", GradientUnit(c)},
            {"rig", FiniteOrNull(cs.rig(c, k) * per_kn)},
            {"rig_standard_error", FiniteOrNull(cs.rig_se(c, k) * per_kn)},
            {"rig_noise_standard_error",
             FiniteOrNull(cs.rig_noise_se(c, k) * per_kn)}};
        if (sheet.has_model) {
          g["model"] = FiniteOrNull(cs.model(c, k) * per_kn);
          g["model_standard_error"] = FiniteOrNull(cs.model_se(c, k) * per_kn);
          g["model_static"] = FiniteOrNull(cs.static_compliance(c, k) * per_kn);
          g["difference_z"] = FiniteOrNull(cs.z(c, k));
        }
        gradients.push_back(g);
      }
    }
    components.push_back({{"z_a", FiniteOrNull(cs.z_a)},
                          {"logs", cs.sources},
                          {"gradients", gradients}});
  }
  doc["components"] = components;
  Json named = Json::array();
  for (const NamedFigure& f : sheet.named) {
    named.push_back(
        {{"name", f.name},
         {"place", f.place},
         {"unit", f.unit},
         {"rig", f.has_rig ? FiniteOrNull(f.rig) : Json()},
         {"rig_standard_error",
          f.has_rig ? FiniteOrNull(f.rig_standard_error) : Json()},
         {"model", f.has_model ? FiniteOrNull(f.model) : Json()},
         {"model_standard_error",
          f.has_model ? FiniteOrNull(f.model_standard_error) : Json()},
         {"difference_z",
          f.has_rig && f.has_model ? FiniteOrNull(f.z) : Json()},
         {"model_static", FiniteOrNull(f.model_static)}});
  }
  doc["named_figures"] = named;
  if (sheet.has_model) {
    Json compliance = {
        {"rest", Json::array()},
        {"wheel_centre", MatrixJson(sheet.compliance.wheel_centre)}};
    for (int c = 0; c < 6; ++c) {
      compliance["rest"].push_back(
          FiniteOrNull(ChannelDisplayValue(c, sheet.compliance.rest(c))));
    }
    if (sheet.has_contact_patch) {
      compliance["contact_patch_z"] =
          FiniteOrNull(sheet.compliance.contact_patch_z);
      compliance["contact_patch"] = MatrixJson(sheet.compliance.contact_patch);
    }
    doc["compliance"] = compliance;
  } else {
    doc["compliance"] = nullptr;
  }
  Json differing = Json::array();
  for (int c = 0; c < 6; ++c) {
    if (sheet.channel_differs[c]) differing.push_back(kChannelNames[c]);
  }
  doc["differing_channels"] = differing;
  return doc.dump(2) + "\n";
}

namespace {

std::string CsvNumber(double value) {
  if (!std::isfinite(value)) return "";
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

// A CSV field: quoted when it holds a comma or a quote.
std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char ch : text) {
    if (ch == '"') quoted += '"';
    quoted += ch;
  }
  return quoted + "\"";
}

struct CsvRow {
  std::string log, phi, z_a, channel, figure, unit;
  double rig = NAN, rig_se = NAN, rig_noise_se = NAN;
  double model = NAN, model_se = NAN, z = NAN;
  bool differs = false;
};

void AppendRow(const CsvRow& r, std::string* csv) {
  *csv += CsvField(r.log) + "," + r.phi + "," + r.z_a + "," +
          CsvField(r.channel) + "," + CsvField(r.figure) + "," +
          CsvField(r.unit) + "," + CsvNumber(r.rig) + "," +
          CsvNumber(r.rig_se) + "," + CsvNumber(r.rig_noise_se) + "," +
          CsvNumber(r.model) + "," + CsvNumber(r.model_se) + "," +
          CsvNumber(r.z) + "," + (r.differs ? "1" : "0") + "\n";
}

// The row of a compared figure (a gradient, a loop width), in display
// units (`scale` from SI).
CsvRow FigureRow(CsvRow row, const char* figure, const std::string& unit,
                 double scale, const Figure& rig, bool has_model, double model,
                 double model_se, const Comparison& comparison) {
  row.figure = figure;
  row.unit = unit;
  row.rig = rig.value * scale;
  row.rig_se = rig.standard_error * scale;
  row.rig_noise_se = rig.noise_standard_error * scale;
  if (has_model) {
    row.model = model * scale;
    row.model_se = model_se * scale;
    row.z = comparison.z;
    row.differs = comparison.differs;
  }
  return row;
}

void AppendRunRows(const KcSheet& sheet, const RunSheet& run,
                   std::string* csv) {
  for (int c = 0; c < 6; ++c) {
    CsvRow base;
    base.log = run.source;
    base.phi = CsvNumber(run.phi / kDegree);
    base.z_a = CsvNumber(run.z_a);
    base.channel = kChannelNames[c];
    const double per_kn = PerKilonewton(c, 1.0);
    AppendRow(FigureRow(base, "gradient", GradientUnit(c), per_kn,
                        run.rig[c].gradient, sheet.has_model,
                        run.model[c].gradient.value, run.model_gradient_se[c],
                        run.gradient_difference[c]),
              csv);
    for (int b = 0; b < 2; ++b) {
      const LineFit& line = b == 0 ? run.rig[c].rising : run.rig[c].falling;
      if (line.samples == 0) continue;
      CsvRow l = base;
      l.figure = b == 0 ? "rising_gradient" : "falling_gradient";
      l.unit = GradientUnit(c);
      l.rig = line.slope * per_kn;
      l.rig_se = line.standard_error * per_kn;
      l.rig_noise_se = line.noise_standard_error * per_kn;
      if (sheet.has_model) {
        l.model = (b == 0 ? run.model[c].rising : run.model[c].falling).slope *
                  per_kn;
      }
      AppendRow(l, csv);
    }
    if (!run.has_falling) continue;
    const double display = ChannelDisplayValue(c, 1.0);
    AppendRow(
        FigureRow(base, "loop_width", ChannelDisplayUnit(c), display,
                  run.rig[c].loop_width, sheet.has_model,
                  run.model[c].loop_width.value, run.model_loop_width_se[c],
                  run.loop_width_difference[c]),
        csv);
    CsvRow a = base;
    a.figure = "loop_area";
    a.unit = AreaUnit(c);
    a.rig = AreaDisplay(c, run.rig[c].loop_area);
    if (sheet.has_model) a.model = AreaDisplay(c, run.model[c].loop_area);
    AppendRow(a, csv);
  }
}

}  // namespace

std::string KcSheetToCsv(const KcSheet& sheet) {
  std::string csv =
      "log,phi_deg,z_a_m,channel,figure,unit,rig,rig_standard_error,"
      "rig_noise_standard_error,model,model_standard_error,z,differs\n";
  for (const RunSheet& run : sheet.runs) AppendRunRows(sheet, run, &csv);
  for (const NamedFigure& f : sheet.named) {
    CsvRow r;
    r.channel = f.place;
    r.figure = f.name;
    r.unit = f.unit;
    if (f.has_rig) {
      r.rig = f.rig;
      r.rig_se = f.rig_standard_error;
    }
    if (f.has_model) {
      r.model = f.model;
      r.model_se = f.model_standard_error;
      if (f.has_rig) r.z = f.z;
    }
    AppendRow(r, &csv);
    CsvRow static_row;
    static_row.channel = f.place;
    static_row.figure = f.name + " (suspension static)";
    static_row.unit = f.unit;
    static_row.model = f.model_static;
    AppendRow(static_row, &csv);
  }
  return csv;
}

std::string KcSheetSummary(const KcSheet& sheet) {
  std::string text;
  char line[256];
  for (const RunSheet& run : sheet.runs) {
    // The log's name may be long: only the numbers go through the buffer.
    std::snprintf(line, sizeof line, ": phi %.1f deg, z_a %.3f m, Fmax %.2f kN",
                  run.phi / kDegree, run.z_a, run.fmax * 1e-3);
    text += std::string("K&C sheet (") + ConventionName(sheet.convention) +
            ") of " + run.source + line +
            (sheet.has_model ? ", model " + sheet.model_name : "") + "\n";
    text += sheet.has_model
                ? "  channel  gradient   rig                model        "
                  "[se]   loop width   rig             model      [se]\n"
                : "  channel  gradient   rig                loop width   "
                  "rig\n";
    for (int c = 0; c < 6; ++c) {
      const double g = PerKilonewton(c, 1.0);
      const double w = ChannelDisplayValue(c, 1.0);
      const ChannelFigures& r = run.rig[c];
      std::snprintf(line, sizeof line, "  %-7s  %-8s %+9.5f ±%8.5f",
                    kChannelNames[c], GradientUnit(c).c_str(),
                    r.gradient.value * g, r.gradient.standard_error * g);
      text += line;
      if (sheet.has_model) {
        const Comparison& d = run.gradient_difference[c];
        std::snprintf(line, sizeof line, "  %+9.5f %+6.1f%s",
                      run.model[c].gradient.value * g, d.z,
                      d.differs ? " <<" : "   ");
        text += line;
      }
      if (run.has_falling) {
        std::snprintf(line, sizeof line, "   %-4s %+9.5f ±%8.5f",
                      ChannelDisplayUnit(c), r.loop_width.value * w,
                      r.loop_width.standard_error * w);
        text += line;
        if (sheet.has_model) {
          const Comparison& d = run.loop_width_difference[c];
          std::snprintf(line, sizeof line, "  %+9.5f %+6.1f%s",
                        run.model[c].loop_width.value * w, d.z,
                        d.differs ? " <<" : "");
          text += line;
        }
      }
      text += "\n";
    }
  }
  if (!sheet.named.empty()) {
    text +=
        "standard figures (suspension static: the model's analytic "
        "compliance, without the rig's):\n";
    std::snprintf(line, sizeof line, "  %-26s %-14s %-19s  %-9s %6s     %s\n",
                  "figure", "at", "rig", "model", "[se]", "suspension static");
    text += line;
  }
  for (const NamedFigure& f : sheet.named) {
    std::snprintf(line, sizeof line, "  %-26s %-14s ", f.name.c_str(),
                  f.place.c_str());
    text += line;
    if (f.has_rig) {
      std::snprintf(line, sizeof line, "%+9.5f ±%8.5f", f.rig,
                    f.rig_standard_error);
      text += line;
    } else {
      text += std::string(19, ' ');
    }
    if (f.has_model && f.has_rig) {
      std::snprintf(line, sizeof line, "  %+9.5f %+6.1f%s", f.model, f.z,
                    std::abs(f.z) > sheet.flag_z ? " <<" : "   ");
      text += line;
    } else {
      text += std::string(22, ' ');
    }
    std::snprintf(line, sizeof line, "  %+9.5f %s\n", f.model_static,
                  f.unit.c_str());
    text += line;
  }
  std::string differing;
  for (int c = 0; c < 6; ++c) {
    if (sheet.channel_differs[c]) {
      differing +=
          std::string(differing.empty() ? "" : ", ") + kChannelNames[c];
    }
  }
  if (sheet.has_model) {
    std::snprintf(line, sizeof line, "%g", sheet.flag_z);
    text += differing.empty()
                ? "model and rig agree within their standard errors (|z| <= " +
                      std::string(line) + ") on every channel\n"
                : "model and rig differ (|z| > " + std::string(line) +
                      ") on: " + differing +
                      " — run kcrig diagnose on these logs\n";
  }
  return text;
}

}  // namespace kcrig
