#include "diagnosis/diagnosis_io.h"

#include <cmath>
#include <cstdio>

#include "base/json_reader.h"
#include "base/json_writer.h"
#include "estimator/estimate_io.h"
#include "nlohmann/json.hpp"

namespace kcrig {
namespace {

using Json = nlohmann::ordered_json;

Json PerChannel(const Vec6<double>& v) {
  Json out;
  for (int k = 0; k < 6; ++k) out[kChannelNames[k]] = FiniteOrNull(v(k));
  return out;
}

// Each moved hard point: its move [m] and the move's covariance [m^2]
// (the 95 % region: dT C^-1 d <= region_chi2_95); null covariance where a
// coordinate is not determined.
Json HardPointsToJson(const std::vector<HardPointMove>& moves) {
  Json out = Json::array();
  for (const HardPointMove& m : moves) {
    Json covariance = Json::array();
    for (int j = 0; j < 3; ++j) {
      Json row = Json::array();
      for (int k = 0; k < 3; ++k)
        row.push_back(FiniteOrNull(m.covariance(j, k)));
      covariance.push_back(row);
    }
    out.push_back(
        {{"point", m.point},
         {"configured_m", {m.configured(0), m.configured(1), m.configured(2)}},
         {"displacement_m",
          {m.displacement(0), m.displacement(1), m.displacement(2)}},
         {"distance_m", m.displacement.norm()},
         {"covariance_m2", m.bounded ? covariance : Json(nullptr)},
         {"at_bound", m.at_bound},
         {"region_chi2_95", kHardPointRegion95}});
  }
  return out;
}

Json SliceJson(const GapSlice& s) {
  return {{"name", s.name},
          {"samples", s.samples},
          {"score", FiniteOrNull(s.score)},
          {"score_per_channel", PerChannel(s.channel_score)},
          {"excess_share", FiniteOrNull(s.excess_share)},
          {"mean_residual", PerChannel(s.mean)},
          {"rms", PerChannel(s.rms)}};
}

Json CandidateJson(const CandidateScore& s) {
  Json out = {{"model", s.model}, {"ok", s.ok}};
  if (!s.ok) {
    out["error"] = s.error;
    return out;
  }
  out["parameters"] = ParameterEstimatesToJson(s.fit.result.parameters);
  out["residual_correlation"] = FiniteOrNull(s.fit.result.residual_correlation);
  out["interval_widening"] = FiniteOrNull(s.fit.result.interval_widening);
  out["num_parameters"] = s.num_parameters;
  out["train_chi2"] = FiniteOrNull(s.train_chi2);
  out["bic"] = FiniteOrNull(s.bic);
  out["aicc"] = FiniteOrNull(s.aicc);
  // Not computed is null, never a zero that reads as "below the noise".
  out["score"] = s.scored ? FiniteOrNull(s.score) : Json(nullptr);
  out["heldout_rms"] = s.heldout ? PerChannel(s.heldout_rms) : Json(nullptr);
  out["gap_closed"] = s.scored ? FiniteOrNull(s.gap_closed) : Json(nullptr);
  out["ljung_box_p"] = s.scored ? FiniteOrNull(s.ljung_box_p) : Json(nullptr);
  out["iterations"] = s.fit.result.iterations;
  out["converged"] = s.fit.result.converged;
  out["at_far_bound"] = s.at_far_bound;
  return out;
}

// A number that may be null (not computed): NaN then.
double NumberOrNan(const nlohmann::json& node, const char* key) {
  const nlohmann::json& value = node.value(key, nlohmann::json(nullptr));
  return value.is_null() ? std::nan("") : value.get<double>();
}

Status ReadCandidate(const nlohmann::json& node, const std::string& where,
                     CandidateScore* s) {
  s->model = node.value("model", "nominal");
  s->ok = node.value("ok", true);
  if (!s->ok) return Status::Ok();
  s->score = NumberOrNan(node, "score");
  s->scored = std::isfinite(s->score);
  s->gap_closed = NumberOrNan(node, "gap_closed");
  s->bic = NumberOrNan(node, "bic");
  s->at_far_bound = node.value("at_far_bound", false);
  const nlohmann::json& parameters =
      node.value("parameters", nlohmann::json::array());
  for (size_t i = 0; i < parameters.size(); ++i) {
    ParameterEstimate& p = s->fit.result.parameters.emplace_back();
    KCRIG_RETURN_IF_ERROR(ReadParameterEstimate(
        parameters[i],
        where + ": " + s->model + ".parameters[" + std::to_string(i) + "]",
        &p));
    s->fit.values.push_back(p.value);
  }
  return Status::Ok();
}

GapSlice ReadSlice(const nlohmann::json& node) {
  GapSlice s;
  s.name = node.value("name", "");
  s.samples = node.value("samples", 0);
  const nlohmann::json& per =
      node.value("score_per_channel", nlohmann::json::object());
  for (int k = 0; k < 6; ++k)
    s.channel_score(k) = NumberOrNan(per, kChannelNames[k]);
  return s;
}

std::vector<std::string> ReadStrings(const nlohmann::json& doc,
                                     const char* key) {
  std::vector<std::string> out;
  for (const nlohmann::json& item : doc.value(key, nlohmann::json::array())) {
    if (item.is_string()) out.push_back(item.get<std::string>());
  }
  return out;
}

Status ReadDiagnosisDocument(const std::string& path, const nlohmann::json& doc,
                             DiagnosisFile* file) {
  DiagnosisResult& r = file->result;
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "verdict", path, &r.verdict));
  r.model = doc.value("model", r.verdict);
  r.components = ReadStrings(doc, "components");
  KCRIG_RETURN_IF_ERROR(ReadField(doc, "reason", path, &r.reason));
  r.confidence = doc.value("confidence", "");
  r.scoring = doc.value("scoring", "");
  const nlohmann::json& localisation =
      doc.value("localisation", nlohmann::json::object());
  for (const auto& [key, slices] : {std::pair{"load_magnitude", &r.magnitude},
                                    {"load_direction", &r.direction}}) {
    for (const nlohmann::json& s :
         localisation.value(key, nlohmann::json::array())) {
      slices->push_back(ReadSlice(s));
    }
  }
  file->has_nominal = doc.contains("nominal");
  if (file->has_nominal) {
    KCRIG_RETURN_IF_ERROR(ReadCandidate(doc["nominal"], path, &r.nominal));
  }
  for (const nlohmann::json& c :
       doc.value("candidates", nlohmann::json::array())) {
    KCRIG_RETURN_IF_ERROR(ReadCandidate(c, path, &r.ranking.emplace_back()));
  }
  file->logs = ReadStrings(doc, "logs");
  file->holdout = ReadStrings(doc, "holdout");
  return Status::Ok();
}

}  // namespace

Status ReadDiagnosisFile(const std::string& path, DiagnosisFile* file) {
  *file = DiagnosisFile();
  nlohmann::json doc;
  KCRIG_RETURN_IF_ERROR(ReadJsonFile(path, &doc));
  return GuardedRead(path,
                     [&] { return ReadDiagnosisDocument(path, doc, file); });
}

namespace {

Json StiffnessDriftJson(const std::vector<StiffnessDrift>& drifts) {
  Json out = Json::array();
  for (const StiffnessDrift& d : drifts) {
    Json se = Json::array();
    for (double v : d.standard_errors) se.push_back(FiniteOrNull(v));
    out.push_back({{"parameter", d.parameter},
                   {"unit", "N/m"},
                   {"per_log", d.values},
                   {"standard_errors", se},
                   {"max_z", FiniteOrNull(d.max_z)},
                   {"drifts", d.drifts}});
  }
  return out;
}

// The screening of the model parameters a wrong "known" value may hide in.
Json ParameterLeadsJson(const std::vector<ParameterLead>& leads) {
  Json out = Json::array();
  for (const ParameterLead& lead : leads) {
    out.push_back({{"parameter", lead.name},
                   {"component", ComponentOfParameter(lead.name)},
                   {"chi2_drop", FiniteOrNull(lead.chi2_drop)},
                   {"freed", lead.freed}});
  }
  return out;
}

Json GapJson(const DiagnosisResult& r) {
  return {{"present", r.gap},
          {"chi2", FiniteOrNull(r.chi2)},
          {"dof", r.dof},
          {"chi2_p", FiniteOrNull(r.chi2_p)},
          {"ljung_box_p", FiniteOrNull(r.ljung_box_p)},
          {"score", FiniteOrNull(r.dof > 0 ? r.chi2 / r.dof : 0)},
          {"discretisation_sigma", FiniteOrNull(r.discretisation)},
          {"continuous_limit", r.continuous_limit},
          {"source", r.gap_source}};
}

// Where the gap lies: channels, load magnitude and direction, frequency
// bands, lags, the stiffnesses' drift from log to log.
Json LocalisationJson(const DiagnosisResult& r) {
  Json localisation;
  Json channels = Json::array();
  for (int k = 0; k < static_cast<int>(r.channels.size()); ++k) {
    const GapSlice& s = r.channels[k];
    channels.push_back({{"channel", s.name},
                        {"unit", k < 3 ? "m" : "rad"},
                        {"rms", FiniteOrNull(s.rms(k))},
                        {"score", FiniteOrNull(s.score)},
                        {"excess_share", FiniteOrNull(s.excess_share)},
                        {"mean_residual", FiniteOrNull(s.mean(k))}});
  }
  localisation["channels"] = channels;
  Json magnitude = Json::array(), direction = Json::array();
  for (const GapSlice& s : r.magnitude) magnitude.push_back(SliceJson(s));
  for (const GapSlice& s : r.direction) direction.push_back(SliceJson(s));
  localisation["load_magnitude"] = magnitude;
  localisation["load_direction"] = direction;
  Json bands = Json::array();
  for (const FrequencyBand& b : r.bands) {
    bands.push_back({{"low_hz", b.low_hz},
                     {"high_hz", b.high_hz},
                     {"energy_share", FiniteOrNull(b.energy_share)},
                     {"white_noise_share", FiniteOrNull(b.white_share)}});
  }
  localisation["frequency_bands"] = bands;
  Json lags = Json::array();
  for (const LagCorrelation& c : r.lags) {
    lags.push_back({{"channel", c.channel},
                    {"force_lag_s", c.force_lag},
                    {"force_correlation", FiniteOrNull(c.force_correlation)},
                    {"rate_lag_s", c.rate_lag},
                    {"rate_correlation", FiniteOrNull(c.rate_correlation)}});
  }
  localisation["lags"] = lags;
  localisation["stiffness_drift"] = StiffnessDriftJson(r.drift);
  localisation["drift_detected"] = r.drift_detected;
  return localisation;
}

// How far the gap shrinks: the verdict's model against the nominal one.
Json QuantificationJson(const DiagnosisResult& r,
                        const CandidateScore& chosen) {
  Json stiffness = Json::array();
  for (int i = 0; i < kNumBushings; ++i) {
    const ParameterEstimate& before = r.nominal.fit.result.parameters[i];
    const ParameterEstimate& after = chosen.fit.result.parameters[i];
    stiffness.push_back(
        {{"name", before.name},
         {"unit", "N/m"},
         {"before", before.value},
         {"after", after.value},
         {"after_standard_error", FiniteOrNull(after.standard_error)},
         {"bias", before.value - after.value}});
  }
  const Json effect =
      ParameterEstimatesToJson(chosen.fit.result.parameters, kNumBushings);
  return {{"model", chosen.model},
          {"scored_on", r.scoring},
          {"rms_before", r.nominal.heldout ? PerChannel(r.nominal.heldout_rms)
                                           : Json(nullptr)},
          {"rms_after",
           chosen.heldout ? PerChannel(chosen.heldout_rms) : Json(nullptr)},
          {"score_before", FiniteOrNull(r.nominal.score)},
          {"score_after", FiniteOrNull(chosen.score)},
          {"gap_closed", FiniteOrNull(chosen.gap_closed)},
          {"leaves_noise", r.leaves_noise},
          {"effect_parameters", effect},
          {"hard_points", HardPointsToJson(r.hard_points)},
          {"stiffness", stiffness}};
}

Json DiscrepancyJson(const Discrepancy& d) {
  Json terms = Json::array();
  for (const DiscrepancyTerm& t : d.terms) {
    terms.push_back({{"component", t.component},
                     {"term", t.term},
                     {"coefficient", FiniteOrNull(t.coefficient)},
                     {"unit", t.unit},
                     {"force_rms_n", FiniteOrNull(t.force_rms)},
                     {"words", t.words}});
  }
  return {{"terms", terms},
          {"validated_on", d.validated_on},
          {"gap_closed", FiniteOrNull(d.gap_closed)},
          {"training_gap_closed", FiniteOrNull(d.training_gap_closed)},
          {"predictive", d.predictive},
          {"text", d.text}};
}

}  // namespace

std::string DiagnosisToJson(const DiagnosisResult& r,
                            const std::vector<std::string>& training_logs,
                            const std::vector<std::string>& holdout_logs,
                            const std::string& design_json) {
  Json doc;
  doc["format"] = "kcrig diagnose 1";
  doc["logs"] = training_logs;
  doc["holdout"] = holdout_logs;
  doc["verdict"] = r.verdict;
  doc["model"] = r.model;
  doc["components"] = r.components;
  doc["confidence"] = r.confidence;
  doc["rival"] = r.rival.empty()
                     ? Json(nullptr)
                     : Json({{"model", r.rival},
                             {"separation", FiniteOrNull(r.rival_separation)}});
  doc["parameter_screening"] = ParameterLeadsJson(r.parameter_leads);
  doc["reason"] = r.reason;
  doc["gap"] = GapJson(r);
  if (r.prediction.assessed) {
    doc["holdout_prediction"] = Json::parse(AdequacyToJson(r.prediction));
  }
  doc["localisation"] = LocalisationJson(r);
  doc["scoring"] = r.scoring;
  doc["nominal"] = CandidateJson(r.nominal);
  Json ranking = Json::array();
  for (const CandidateScore& s : r.ranking) ranking.push_back(CandidateJson(s));
  doc["candidates"] = ranking;
  for (const CandidateScore& s : r.ranking) {
    if (s.model == r.model) doc["quantification"] = QuantificationJson(r, s);
  }
  if (!r.discrepancy.validated_on.empty()) {
    doc["discrepancy"] = DiscrepancyJson(r.discrepancy);
  }
  if (!r.ambiguous_a.empty()) {
    doc["ambiguous"] = {r.ambiguous_a, r.ambiguous_b};
  }
  if (!design_json.empty()) {
    doc["discriminating_design"] = Json::parse(design_json);
  }
  return doc.dump(2) + "\n";
}

namespace {

// The gap test and, when there is one, the hold-out's prediction.
std::string GapSummary(const DiagnosisResult& r) {
  std::string out;
  char line[400];
  auto add = [&out, &line] { out += line; };
  std::snprintf(line, sizeof(line),
                "gap test: chi2/dof %.3f (p %.2g), Ljung-Box p %.2g%s -> %s\n",
                r.dof > 0 ? r.chi2 / r.dof : 0.0, r.chi2_p, r.ljung_box_p,
                r.continuous_limit ? " (the model's discretisation error set "
                                     "apart)"
                                   : "",
                r.gap_source == "prediction"
                    ? "a gap beyond the sensor noise (training and hold-out "
                      "logs fitted together)"
                : r.gap ? "a gap beyond the sensor noise"
                        : "consistent with the sensor noise");
  add();
  if (r.prediction.assessed) {
    out += "hold-out prediction by the nominal fit to the training logs: " +
           AdequacyLine(r.prediction) + "\n";
  }
  if (r.gap_source == "prediction") {
    out +=
        "  fits the training logs, mispredicts the hold-out: an effect "
        "absorbed by biased stiffnesses; the hold-out joined the training "
        "logs for the attribution\n";
  }
  return out;
}

// Where the gap lies: per channel, load regime, band and log.
std::string LocalisationSummary(const DiagnosisResult& r) {
  std::string out;
  char line[400];
  auto add = [&out, &line] { out += line; };
  std::snprintf(line, sizeof(line), "  %-8s %12s %8s %8s %12s\n", "channel",
                "rms", "score", "excess", "mean");
  add();
  for (int k = 0; k < static_cast<int>(r.channels.size()); ++k) {
    const GapSlice& s = r.channels[k];
    // Without a gap the excess is noise and its shares mean nothing.
    char share[16] = "       -";
    if (r.gap)
      std::snprintf(share, sizeof(share), "%7.0f%%", 100 * s.excess_share);
    std::snprintf(line, sizeof(line), "  %-8s %8.4f %-3s %8.2f %s %8.4f %s\n",
                  s.name.c_str(), ChannelDisplayValue(k, s.rms(k)),
                  ChannelDisplayUnit(k), s.score, share,
                  ChannelDisplayValue(k, s.mean(k)), ChannelDisplayUnit(k));
    add();
  }
  out += r.gap ? "  load regime (score, share of excess):"
               : "  load regime (score):";
  for (const std::vector<GapSlice>* group : {&r.magnitude, &r.direction}) {
    for (const GapSlice& s : *group) {
      if (s.samples == 0) continue;
      if (r.gap) {
        std::snprintf(line, sizeof(line), " %s %.2f/%.0f%%", s.name.c_str(),
                      s.score, 100 * s.excess_share);
      } else {
        std::snprintf(line, sizeof(line), " %s %.2f", s.name.c_str(), s.score);
      }
      add();
    }
  }
  out += "\n  residual spectrum (share vs white):";
  for (const FrequencyBand& b : r.bands) {
    std::snprintf(line, sizeof(line), " %g-%gHz %.0f%%/%.0f%%", b.low_hz,
                  b.high_hz, 100 * b.energy_share, 100 * b.white_share);
    add();
  }
  out += "\n";
  if (!r.drift.empty()) {
    out += "  stiffness per log [N/mm]:";
    for (const StiffnessDrift& d : r.drift) {
      std::snprintf(line, sizeof(line), " %s", d.parameter.c_str());
      add();
      for (double v : d.values) {
        std::snprintf(line, sizeof(line), " %.0f", v * 1e-3);
        add();
      }
      std::snprintf(line, sizeof(line), " (z %.1f%s)", d.max_z,
                    d.drifts ? ", drifts" : "");
      add();
    }
    out += "\n";
  }
  return out;
}

// The candidates' table, the nominal model last.
std::string RankingSummary(const DiagnosisResult& r) {
  std::string out;
  char line[400];
  auto add = [&out, &line] { out += line; };
  if (!r.ranking.empty()) {
    std::snprintf(line, sizeof(line),
                  "candidates (scored by %s; score 1 = noise floor):\n"
                  "  %-36s %6s %9s %8s %12s\n",
                  r.scoring.c_str(), "model", "params", "score", "closed",
                  "dBIC");
    add();
    for (const CandidateScore& s : r.ranking) {
      if (!s.ok) {
        std::snprintf(line, sizeof(line), "  %-36s failed: %s\n",
                      s.model.c_str(), s.error.c_str());
      } else {
        std::snprintf(line, sizeof(line), "  %-36s %6d %9.3f %7.0f%% %12.1f\n",
                      s.model.c_str(), s.num_parameters, s.score,
                      100 * s.gap_closed, s.bic - r.nominal.bic);
      }
      add();
    }
    std::snprintf(line, sizeof(line), "  %-36s %6d %9.3f %7s  %12s\n",
                  "nominal", r.nominal.num_parameters, r.nominal.score, "0%",
                  "0.0");
    add();
  }
  return out;
}

// The verdict's model: held-out rms before and after, its fitted
// parameters beside the nominal stiffnesses, the intervals' widening.
std::string ChosenFitSummary(const DiagnosisResult& r,
                             const CandidateScore& s) {
  std::string out;
  char line[400];
  auto add = [&out, &line] { out += line; };
  out += s.heldout ? "  held-out rms before -> after:"
                   : "  (one log, no hold-out: no held-out rms)";
  for (int k = 0; k < 6 && s.heldout; ++k) {
    std::snprintf(line, sizeof(line), " %s %.4f->%.4f %s", kChannelNames[k],
                  ChannelDisplayValue(k, r.nominal.heldout_rms(k)),
                  ChannelDisplayValue(k, s.heldout_rms(k)),
                  ChannelDisplayUnit(k));
    add();
  }
  out += "\n  fitted:";
  for (size_t i = 0; i < s.fit.result.parameters.size(); ++i) {
    const ParameterEstimate& p = s.fit.result.parameters[i];
    const double scale = DisplayScale(p);
    // What the engineer compares: the stiffness before the effect was
    // modelled; a mount compliance also as a stiffness.
    char extra[64] = "";
    if (i < kNumBushings) {
      std::snprintf(extra, sizeof(extra), " (was %.0f)",
                    r.nominal.fit.result.parameters[i].value * scale);
    } else if (p.unit == "m/N" && p.value > 0) {
      std::snprintf(extra, sizeof(extra), " (k %.0f N/mm)", 1e-3 / p.value);
    }
    std::snprintf(
        line, sizeof(line), " %s %.4g +- %.2g %s%s", p.name.c_str(),
        p.value * scale,
        std::isfinite(p.standard_error) ? (p.ci95_high - p.value) * scale : NAN,
        DisplayUnit(p).c_str(), extra);
    add();
  }
  out += "\n" + IntervalWideningSummary(s.fit.result);
  return out;
}

std::string VerdictSummary(const DiagnosisResult& r) {
  std::string where;
  for (const std::string& c : r.components) {
    where += (where.empty() ? " in " : " and ") + c;
  }
  if (r.model == r.verdict) where.clear();  // everywhere: nothing to place
  // The reason is as long as what it names: no fixed buffer.
  return "verdict: " + r.verdict + where +
         (r.confidence.empty() ? "" : ", confidence " + r.confidence) + " — " +
         r.reason + "\n";
}

}  // namespace

std::string DiagnosisSummary(const DiagnosisResult& r) {
  std::string out = GapSummary(r) + LocalisationSummary(r) + RankingSummary(r) +
                    VerdictSummary(r);
  for (const CandidateScore& s : r.ranking) {
    if (s.model == r.model) out += ChosenFitSummary(r, s);
  }
  return out;
}

}  // namespace kcrig
