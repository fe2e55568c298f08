#include "diagnosis/internal/discrepancy.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>

#include "Eigen/Cholesky"
#include "Eigen/LU"
#include "rt_core/model/plant_effects.h"
#include "rt_core/model/suspension_model.h"

namespace kcrig {
namespace {

constexpr int kNumElements = kNumBushings + 1;  // the bushings, the strut
constexpr int kStrut = kNumBushings;
// A column of one term in every bushing at once.
constexpr int kEveryBushingColumn = kNumElements;

enum Kind { kElongation, kSquare, kCube, kStep, kRate, kFriction, kDrift };
constexpr int kNumKinds = 7;
struct KindInfo {
  const char* name;
  const char* unit;  // of the coefficient
};
constexpr KindInfo kKinds[kNumKinds] = {
    {"d", "N/m"},   {"d^2", "N/m^2"}, {"d^3", "N/m^3"}, {"sign(d)", "N"},
    {"v", "N s/m"}, {"sign(v)", "N"}, {"t*d", "N/m"}};

// One log along the nominal fit, per sample: each element's elongation
// and rate, the weighted static response of the six channels to a unit
// tension in each element (zero rows where not observed), the weighted
// residual and the time over the log in [0, 1].
struct Trace {
  std::vector<Vec6<double>> elongation, rate, residual;
  std::vector<Mat6<double>> response;
  std::vector<double> time;
  long observed_rows = 0;
};

SuspensionParameters<double> FittedParameters(
    const EffectModel& model, const std::vector<double>& values) {
  std::vector<double> theta(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    theta[i] = model.ToTheta(static_cast<int>(i), values[i]);
  }
  SuspensionParameters<double> parameters;
  PlantEffects effects;
  model.Build(theta.data(), &parameters, &effects);
  return parameters;
}

// The pose the rig went through: the nominal fit's less its residual,
// averaged over kSmoothing samples either side (within the observed
// samples) so that the terms see the true elongations, not the noise. A
// large missing force moves the elements away from the nominal
// trajectory; a term evaluated there would be biased.
constexpr int kSmoothing = 10;

std::vector<Vec6<double>> SmoothedMeasuredPose(
    const Experiment& e, const std::vector<Vec6<double>>& pose,
    const std::vector<Vec6<double>>& weighted_residual) {
  const long n = static_cast<long>(pose.size());
  std::vector<Vec6<double>> offset(pose.size(), Vec6<double>::Zero());
  for (long j = 0; j < n; ++j) {
    Vec6<double> sum = Vec6<double>::Zero();
    int count = 0;
    for (long i = std::max(0L, j - kSmoothing);
         i <= std::min(n - 1, j + kSmoothing); ++i) {
      if (!Observed(e, static_cast<size_t>(i))) continue;
      sum += weighted_residual[i].cwiseProduct(e.sigma);
      ++count;
    }
    offset[j] = count > 0 ? Vec6<double>(sum / count) : Vec6<double>::Zero();
  }
  std::vector<Vec6<double>> out(pose.size());
  for (long j = 0; j < n; ++j) out[j] = pose[j] - offset[j];
  return out;
}

Status TraceLog(const EffectModel& model, const std::vector<double>& values,
                const SuspensionModel<double>& suspension, const Experiment& e,
                double step, Trace* trace) {
  std::vector<Vec6<double>> pose;  // the nominal model senses its pose
  KCRIG_RETURN_IF_ERROR(SimulateEffectModel(model, values, e, step, &pose));
  trace->residual = WeightedResidualsOf(e, pose);
  const size_t n = pose.size();
  const std::vector<Vec6<double>> measured_pose =
      SmoothedMeasuredPose(e, pose, trace->residual);
  std::vector<Vec6<double>> nominal_elongation(n);
  trace->elongation.resize(n);
  trace->response.resize(n);
  trace->time.resize(n);
  for (size_t j = 0; j < n; ++j) {
    // The response along the nominal trajectory; the terms along the
    // measured one.
    Mat6<double> directions, measured_directions;
    suspension.ElementGeometry(pose[j], &nominal_elongation[j], &directions);
    suspension.ElementGeometry(measured_pose[j], &trace->elongation[j],
                               &measured_directions);
    RigLoad<double> load;
    load.force = e.forces[j];
    load.point << 0, 0, e.z_a;
    GeneralizedForce<double> g;
    suspension.Evaluate(load, pose[j], Vec6<double>::Zero(), true, &g);
    Mat6<double> response =
        -Eigen::PartialPivLU<Mat6<double>>(g.dq_dy).solve(directions);
    const bool seen = Observed(e, j);
    for (int k = 0; k < 6; ++k) {
      response.row(k) *= seen ? 1.0 / e.sigma(k) : 0.0;
    }
    trace->response[j] = response;
    trace->time[j] = n > 1 ? static_cast<double>(j) / (n - 1) : 0.0;
    trace->observed_rows += seen ? 6 : 0;
  }
  // Rates along the nominal trajectory: the measured one, differentiated,
  // is noise at the turns of the ramp, where sign(v) decides.
  trace->rate.assign(n, Vec6<double>::Zero());
  for (size_t j = 0; n > 1 && j < n; ++j) {
    const size_t a = j > 0 ? j - 1 : j;
    const size_t b = j + 1 < n ? j + 1 : j;
    trace->rate[j] = (nominal_elongation[b] - nominal_elongation[a]) /
                     (static_cast<double>(b - a) * e.sample_period);
  }
  return Status::Ok();
}

struct Column {
  int element;
  Kind kind;
};

// The smoothing widths of sign(d) and sign(v): a twentieth of each
// element's RMS elongation and rate over the training logs; and the
// elements' stiffnesses (a drift is a fraction of them).
struct Widths {
  Vec6<double> elongation = Vec6<double>::Ones();
  Vec6<double> rate = Vec6<double>::Ones();
  Vec6<double> stiffness = Vec6<double>::Ones();
};

Widths WidthsOf(const std::vector<const Trace*>& traces,
                const SuspensionParameters<double>& parameters) {
  Vec6<double> d2 = Vec6<double>::Zero(), v2 = Vec6<double>::Zero();
  double n = 0;
  for (const Trace* t : traces) {
    for (size_t j = 0; j < t->elongation.size(); ++j) {
      d2 += t->elongation[j].cwiseAbs2();
      v2 += t->rate[j].cwiseAbs2();
      n += 1;
    }
  }
  Widths w;
  const double tiny = std::numeric_limits<double>::min();
  w.elongation = ((d2 / std::max(n, 1.0)).cwiseSqrt() / 20).cwiseMax(tiny);
  w.rate = ((v2 / std::max(n, 1.0)).cwiseSqrt() / 20).cwiseMax(tiny);
  for (int i = 0; i < kNumBushings; ++i) {
    w.stiffness(i) = parameters.bushings[i].stiffness;
  }
  w.stiffness(kStrut) = parameters.spring.stiffness;
  return w;
}

// The term of element `element` (an index, never kEveryBushingColumn).
double TermValue(Kind kind, int element, const Trace& t, size_t j,
                 const Widths& w) {
  const double d = t.elongation[j](element);
  const double v = t.rate[j](element);
  switch (kind) {
    case kElongation:
      return d;
    case kSquare:
      return d * d;
    case kCube:
      return d * d * d;
    case kStep:
      return std::tanh(d / w.elongation(element));
    case kRate:
      return v;
    case kFriction:
      return std::tanh(v / w.rate(element));
    case kDrift:
      return t.time[j] * d;
  }
  return 0;
}

// The elements a column acts in, and the weight of each: a drift of every
// bushing is one fraction of each stiffness, other terms one coefficient.
std::vector<std::pair<int, double>> ElementsOf(const Column& c,
                                               const Widths& w) {
  if (c.element != kEveryBushingColumn) return {{c.element, 1.0}};
  std::vector<std::pair<int, double>> out;
  for (int i = 0; i < kNumBushings; ++i) {
    out.push_back({i, c.kind == kDrift ? w.stiffness(i) : 1.0});
  }
  return out;
}

// The column over the traces, six weighted rows per sample.
Eigen::VectorXd ColumnValues(const Column& c,
                             const std::vector<const Trace*>& traces,
                             const Widths& w) {
  long rows = 0;
  for (const Trace* t : traces) rows += 6L * t->elongation.size();
  Eigen::VectorXd out(rows);
  long row = 0;
  for (const Trace* t : traces) {
    for (size_t j = 0; j < t->elongation.size(); ++j) {
      Vec6<double> entry = Vec6<double>::Zero();
      for (const auto& [element, weight] : ElementsOf(c, w)) {
        entry += t->response[j].col(element) *
                 (weight * TermValue(c.kind, element, *t, j, w));
      }
      out.segment<6>(row) = entry;
      row += 6;
    }
  }
  return out;
}

Eigen::VectorXd Residuals(const std::vector<const Trace*>& traces) {
  long rows = 0;
  for (const Trace* t : traces) rows += 6L * t->residual.size();
  Eigen::VectorXd out(rows);
  long row = 0;
  for (const Trace* t : traces) {
    for (const Vec6<double>& r : t->residual) {
      out.segment<6>(row) = r;
      row += 6;
    }
  }
  return out;
}

long ObservedRows(const std::vector<const Trace*>& traces) {
  long rows = 0;
  for (const Trace* t : traces) rows += t->observed_rows;
  return rows;
}

// Least squares over subsets of normalised columns from Gram matrices, one
// per fold (a log): fits to all folds, and each fold predicted by the fit
// to the others (blocked cross-validation).
class SubsetRegression {
 public:
  // `x` and `y` stacked over the folds; fold f has rows_per_fold[f] rows.
  SubsetRegression(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                   const std::vector<long>& rows_per_fold) {
    long row = 0;
    for (long rows : rows_per_fold) {
      const auto xf = x.middleRows(row, rows);
      const auto yf = y.segment(row, rows);
      folds_.push_back({xf.transpose() * xf, xf.transpose() * yf, yf.dot(yf)});
      row += rows;
    }
    all_ = folds_[0];
    for (size_t f = 1; f < folds_.size(); ++f) {
      all_.gram += folds_[f].gram;
      all_.xy += folds_[f].xy;
      all_.yy += folds_[f].yy;
    }
  }

  int num_folds() const { return static_cast<int>(folds_.size()); }

  // The fit to every fold but `left_out` (-1: to all).
  Eigen::VectorXd Coefficients(const std::vector<int>& set,
                               int left_out = -1) const {
    const int k = static_cast<int>(set.size());
    Eigen::MatrixXd g(k, k);
    Eigen::VectorXd b(k);
    for (int a = 0; a < k; ++a) {
      b(a) =
          all_.xy(set[a]) - (left_out >= 0 ? folds_[left_out].xy(set[a]) : 0.0);
      for (int c = 0; c < k; ++c) {
        g(a, c) = all_.gram(set[a], set[c]) -
                  (left_out >= 0 ? folds_[left_out].gram(set[a], set[c]) : 0);
      }
      g(a, a) += 1e-10;  // columns of unit norm: a tie-breaking ridge
    }
    return g.ldlt().solve(b);
  }
  // Residual sum of squares of the fit to all folds.
  double Rss(const std::vector<int>& set) const {
    return RssOf(all_, set, Coefficients(set));
  }
  // Sum over the folds of each fold's RSS under the fit to the others.
  double CrossValidatedRss(const std::vector<int>& set) const {
    double sum = 0;
    for (int f = 0; f < num_folds(); ++f) {
      sum += RssOf(folds_[f], set, Coefficients(set, f));
    }
    return sum;
  }

 private:
  struct Gram {
    Eigen::MatrixXd gram;
    Eigen::VectorXd xy;
    double yy = 0;
  };
  static double RssOf(const Gram& g, const std::vector<int>& set,
                      const Eigen::VectorXd& b) {
    double rss = g.yy;
    for (size_t a = 0; a < set.size(); ++a) {
      rss -= 2 * b(a) * g.xy(set[a]);
      for (size_t c = 0; c < set.size(); ++c) {
        rss += b(a) * b(c) * g.gram(set[a], set[c]);
      }
    }
    return rss;
  }

  std::vector<Gram> folds_;
  Gram all_;
};

// Forward selection: the nuisance columns always, then the column whose
// addition predicts the folds best (with one fold: fits best), while it
// lowers the RSS by more than `price` and, with folds, the cross-validated
// RSS by more than `min_cv_drop`.
std::vector<int> SelectColumns(const SubsetRegression& regression,
                               const std::vector<int>& nuisance,
                               const std::vector<int>& candidates,
                               int max_terms, double price,
                               double min_cv_drop) {
  const bool validate = regression.num_folds() > 1;
  auto criterion = [&](const std::vector<int>& set) {
    return validate ? regression.CrossValidatedRss(set) : regression.Rss(set);
  };
  std::vector<int> chosen = nuisance;
  double rss = regression.Rss(chosen), score = criterion(chosen);
  for (int step = 0; step < max_terms; ++step) {
    int best = -1;
    double best_score = score;
    for (int c : candidates) {
      if (std::find(chosen.begin(), chosen.end(), c) != chosen.end()) continue;
      std::vector<int> trial = chosen;
      trial.push_back(c);
      const double trial_score = criterion(trial);
      if (trial_score < best_score) {
        best_score = trial_score;
        best = c;
      }
    }
    if (best < 0) break;
    std::vector<int> trial = chosen;
    trial.push_back(best);
    const double trial_rss = regression.Rss(trial);
    if (rss - trial_rss <= price ||
        (validate && score - best_score <= min_cv_drop)) {
      break;
    }
    chosen = trial;
    rss = trial_rss;
    score = best_score;
  }
  return chosen;
}

// A number as `format` prints it ("%.0f").
std::string Number(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

std::string ComponentOf(const Column& c) {
  if (c.element == kEveryBushingColumn)
    return DescribeBushingSet(kEveryBushing);
  if (c.element < kStrut) {
    return std::string(kBushingComponent) +
           std::string(kBushingChassisNames[c.element]);
  }
  return c.kind == kRate || c.kind == kFriction ? "strut:damper"
                                                : "strut:spring";
}

// The term in words, with the physical effect it suggests; `stiffness`
// is the element's rate in the fitted model [N/m].
std::string Words(const Column& c, const DiscrepancyTerm& t, double stiffness) {
  const std::string where =
      c.element == kEveryBushingColumn ? std::string("every bushing")
      : c.element < kStrut
          ? "bushing " + std::string(kBushingChassisNames[c.element])
          : std::string("the strut");
  const std::string about = "about " + Number("%.0f", t.force_rms) + " N";
  const double k = t.coefficient;
  switch (c.kind) {
    case kFriction:
      return "a force of " + about +
             (k > 0
                  ? " opposing the motion of " + where +
                        ", independent of speed: dry friction in " + where + "?"
                  : " along the motion of " + where + ", independent of speed");
    case kRate:
      return "a force proportional to the rate of extension of " + where +
             " (" + Number("%.3g", k) + " N s/m, " + about + ")" +
             (k > 0 ? ": viscous damping in " + where + "?"
                    : ": less damping than modelled, or a lag?");
    case kElongation:
      return "a force proportional to the extension of " + where + " (" +
             about + "): its rate " + Number("%+.1f", 100 * k / stiffness) +
             " % off the configured?";
    case kSquare:
      return "a force growing with the square of the extension of " + where +
             " (" + about + "): asymmetric stiffening in " + where + "?";
    case kCube:
      return "a force growing with the cube of the extension of " + where +
             " (" + about +
             "): " + (k > 0 ? "progressive stiffening" : "softening") + " in " +
             where + "?";
    case kStep:
      return k < 0 ? "a force of " + about +
                         " missing around the rest "
                         "length of " +
                         where + ": free play of about +-" +
                         Number("%.2g", -1e3 * k / stiffness) + " mm in " +
                         where + "?"
                   : "a force of " + about +
                         " stepping with the sign of "
                         "the extension of " +
                         where + ": a preload in " + where + "?";
    case kDrift:
      return "the stiffness of " + where + " drifting by " +
             Number(
                 "%+.1f",
                 100 * (c.element == kEveryBushingColumn ? k : k / stiffness)) +
             " % over the log (" + about + "): temperature?";
  }
  return "";
}

// Mean squared weighted residual over the observed rows (1: noise).
double Score(const Eigen::VectorXd& residual, long observed_rows) {
  return observed_rows > 0 ? residual.squaredNorm() / observed_rows : 0;
}

// The fraction of the gap closed on `rows` observed rows; NaN when the gap
// is within five standard deviations of a score at the noise floor
// (sqrt(2 / rows)): a fraction of noise says nothing.
double GapClosed(double before, double after, long rows) {
  const double floor =
      5 * std::sqrt(2.0 / static_cast<double>(std::max(rows, 1L)));
  return before - 1 > floor ? (before - after) / (before - 1)
                            : std::numeric_limits<double>::quiet_NaN();
}

std::string Sentence(const Discrepancy& d) {
  const std::string where = d.validated_on == "holdout"
                                ? "the held-out gap"
                                : "the gap on the last training log, "
                                  "fitted to the others";
  const std::string closed = Number("%.0f", 100 * d.gap_closed) + " %";
  if (d.terms.empty() || (d.validated_on != "none" && !d.predictive)) {
    std::string text =
        "no sparse force in the links or the strut (their extension, rate "
        "and time) explains the gap";
    if (!d.terms.empty() && std::isnan(d.gap_closed)) {
      text += " that the validation logs show beyond their noise";
    } else if (!d.terms.empty()) {
      text += ": the best terms (" + d.terms[0].component + " " +
              d.terms[0].term + ", ...) close " + closed + " of " + where;
    }
    return text + "; the sensors, the fixture or the load path?";
  }
  std::string text = "the missing force looks like " + d.terms[0].words;
  // A second term a fifth of the first's force or more is worth reading.
  if (d.terms.size() > 1 &&
      d.terms[1].force_rms >= 0.2 * d.terms[0].force_rms) {
    text += "; besides, " + d.terms[1].words;
  }
  if (d.validated_on == "none") return text + " (not validated: one log)";
  return text + "; it closes " + closed + " of " + where;
}

// The candidate columns (each element's terms and every bushing's), the
// bushings' own d as nuisance, evaluated on `fitted` and normalised.
struct Design {
  std::vector<Column> columns;
  std::vector<int> nuisance, candidates;
  Eigen::MatrixXd x;
  Eigen::VectorXd norms;
};

Design MakeDesign(const std::vector<const Trace*>& fitted, const Widths& w) {
  Design d;
  for (int e = 0; e <= kEveryBushingColumn; ++e) {
    for (int kind = 0; kind < kNumKinds; ++kind) {
      // Every bushing's d: a common stiffness scale, within the nuisance.
      if (e == kEveryBushingColumn && kind == kElongation) continue;
      const bool stiffness = kind == kElongation && e < kStrut;
      (stiffness ? d.nuisance : d.candidates)
          .push_back(static_cast<int>(d.columns.size()));
      d.columns.push_back({e, static_cast<Kind>(kind)});
    }
  }
  long rows = 0;
  for (const Trace* t : fitted) rows += 6L * t->residual.size();
  d.x.resize(rows, static_cast<Eigen::Index>(d.columns.size()));
  d.norms.resize(static_cast<Eigen::Index>(d.columns.size()));
  for (size_t c = 0; c < d.columns.size(); ++c) {
    d.x.col(c) = ColumnValues(d.columns[c], fitted, w);
    d.norms(c) =
        std::max(d.x.col(c).norm(), std::numeric_limits<double>::min());
    d.x.col(c) /= d.norms(c);
  }
  return d;
}

// The fitted and the scored logs; returns what the scores are validated on.
std::string SplitForValidation(const std::vector<Trace>& traces,
                               size_t num_training,
                               std::vector<const Trace*>* fitted,
                               std::vector<const Trace*>* scored) {
  for (size_t l = 0; l < traces.size(); ++l) {
    (l < num_training ? fitted : scored)->push_back(&traces[l]);
  }
  if (!scored->empty()) return "holdout";
  if (fitted->size() < 2) return "none";
  scored->push_back(fitted->back());
  fitted->pop_back();
  return "last training log";
}

// Mean squared weighted residual of `set` less the chosen columns' force.
double ScoreAfter(const std::vector<const Trace*>& set, const Design& d,
                  const std::vector<int>& chosen,
                  const Eigen::VectorXd& coefficients, const Widths& w) {
  Eigen::VectorXd r = Residuals(set);
  for (size_t a = 0; a < chosen.size(); ++a) {
    r += ColumnValues(d.columns[chosen[a]], set, w) *
         (coefficients(a) / d.norms(chosen[a]));
  }
  return Score(r, ObservedRows(set));
}

DiscrepancyTerm Describe(const Column& c, double coefficient,
                         const std::vector<const Trace*>& fitted,
                         const Widths& w) {
  DiscrepancyTerm t;
  t.component = ComponentOf(c);
  t.term = kKinds[c.kind].name;
  t.unit = c.element == kEveryBushingColumn && c.kind == kDrift
               ? "-"  // a fraction of each stiffness over the log
               : kKinds[c.kind].unit;
  t.coefficient = coefficient;
  double sum = 0;
  long n = 0;
  for (const Trace* trace : fitted) {
    for (size_t j = 0; j < trace->elongation.size(); ++j) {
      for (const auto& [element, weight] : ElementsOf(c, w)) {
        sum += std::pow(weight * TermValue(c.kind, element, *trace, j, w), 2);
        ++n;
      }
    }
  }
  t.force_rms = std::abs(coefficient) * std::sqrt(sum / std::max(n, 1L));
  t.words = Words(c, t,
                  c.element == kEveryBushingColumn
                      ? w.stiffness.head<kNumBushings>().mean()
                      : w.stiffness(c.element));
  return t;
}

}  // namespace

Status CharacteriseDiscrepancy(const EffectModel& model,
                               const std::vector<double>& values,
                               const std::vector<Experiment>& training,
                               const std::vector<Experiment>& validation,
                               double integrator_step,
                               const DiscrepancyOptions& options,
                               Discrepancy* discrepancy) {
  *discrepancy = Discrepancy();
  const SuspensionParameters<double> parameters =
      FittedParameters(model, values);
  const SuspensionModel<double> suspension(parameters);
  std::vector<Trace> traces(training.size() + validation.size());
  for (size_t l = 0; l < traces.size(); ++l) {
    const Experiment& e =
        l < training.size() ? training[l] : validation[l - training.size()];
    KCRIG_RETURN_IF_ERROR(
        TraceLog(model, values, suspension, e, integrator_step, &traces[l]));
  }
  std::vector<const Trace*> fitted, scored;
  discrepancy->validated_on =
      SplitForValidation(traces, training.size(), &fitted, &scored);

  // Select on the fitted logs; the model is r = -X b (r: sensed - measured).
  const Widths widths = WidthsOf(fitted, parameters);
  const Design design = MakeDesign(fitted, widths);
  const Eigen::VectorXd residual = Residuals(fitted);
  std::vector<long> rows_per_fold;
  for (const Trace* t : fitted) {
    rows_per_fold.push_back(6L * t->residual.size());
  }
  const SubsetRegression regression(design.x, -residual, rows_per_fold);
  const double price =
      std::log(static_cast<double>(std::max(ObservedRows(fitted), 2L))) +
      options.min_bic_difference;
  const std::vector<int> chosen =
      SelectColumns(regression, design.nuisance, design.candidates,
                    options.max_terms, price, options.min_bic_difference);
  const Eigen::VectorXd coefficients = regression.Coefficients(chosen);

  // Score on the fitted and the validation logs; describe the terms.
  discrepancy->training_gap_closed =
      GapClosed(Score(residual, ObservedRows(fitted)),
                ScoreAfter(fitted, design, chosen, coefficients, widths),
                ObservedRows(fitted));
  discrepancy->gap_closed =
      scored.empty()
          ? std::numeric_limits<double>::quiet_NaN()
          : GapClosed(Score(Residuals(scored), ObservedRows(scored)),
                      ScoreAfter(scored, design, chosen, coefficients, widths),
                      ObservedRows(scored));
  for (size_t a = design.nuisance.size(); a < chosen.size(); ++a) {
    discrepancy->terms.push_back(
        Describe(design.columns[chosen[a]],
                 coefficients(a) / design.norms(chosen[a]), fitted, widths));
  }
  std::sort(discrepancy->terms.begin(), discrepancy->terms.end(),
            [](const DiscrepancyTerm& a, const DiscrepancyTerm& b) {
              return a.force_rms > b.force_rms;
            });
  discrepancy->predictive = discrepancy->gap_closed >= options.min_gap_closed;
  discrepancy->text = Sentence(*discrepancy);
  return Status::Ok();
}

}  // namespace kcrig
