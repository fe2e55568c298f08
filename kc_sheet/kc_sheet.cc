#include "kc_sheet/kc_sheet.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "Eigen/Dense"
#include "estimator/effect_model.h"
#include "rt_core/model/channels.h"

namespace kcrig {
namespace {

enum Branch { kRising = 0, kFalling = 1, kNumBranches = 2 };

// The samples of one run that the sheet fits: the force along the
// excitation and the six channels, per branch, in time order.
struct RunSamples {
  std::array<std::vector<int>, kNumBranches> index;  // into the log
  std::vector<double> f;                             // per log sample [N]
  Vec3<double> direction = Vec3<double>::Zero();
};

// The branch of sample j: a rig log's phases where it has them, else the
// excitation's own times (a simulated log starts with the ramp).
std::optional<Branch> BranchOf(const RunLog& log, size_t j) {
  const LogSample& s = log.samples[j];
  if (!log.samples.front().phase.empty()) {
    if (s.phase == RunPhaseName(RunPhase::kRamp)) return kRising;
    if (s.phase == RunPhaseName(RunPhase::kReturn)) return kFalling;
    return std::nullopt;
  }
  const RampExcitation<double>& e = log.metadata.excitation;
  const double t = s.t - log.samples.front().t;
  const double tolerance = 1e-9;
  if (t >= -tolerance && t <= e.duration + tolerance) return kRising;
  const double turn = e.duration + e.hold;
  if (e.return_duration > 0 && t >= turn - tolerance &&
      t <= e.EndTime() + tolerance) {
    return kFalling;
  }
  return std::nullopt;
}

RunSamples CollectSamples(const KcRun& run) {
  RunSamples samples;
  const double phi = run.log->metadata.excitation.phi;
  samples.direction << std::cos(phi), std::sin(phi), 0;
  const Experiment& e = *run.experiment;
  samples.f.resize(e.forces.size());
  for (size_t j = 0; j < e.forces.size(); ++j) {
    samples.f[j] = e.forces[j].dot(samples.direction);
    if (!Observed(e, j)) continue;
    if (const std::optional<Branch> b = BranchOf(*run.log, j)) {
      samples.index[*b].push_back(static_cast<int>(j));
    }
  }
  return samples;
}

// Least squares of y on the columns of x (Householder QR): coefficients,
// (X^T X)^-1 and the residual sum of squares.
struct Regression {
  Eigen::VectorXd beta;
  Eigen::MatrixXd inverse_normal;
  double rss = 0;
  int n = 0;

  double Se(int k) const {
    const int dof = n - static_cast<int>(beta.size());
    return dof > 0 ? std::sqrt(rss / dof * inverse_normal(k, k)) : 0.0;
  }
  double NoiseSe(int k, double sigma) const {
    return sigma * std::sqrt(inverse_normal(k, k));
  }
};

Regression Regress(const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
  Regression r;
  r.n = static_cast<int>(x.rows());
  // Columns scaled to unit norm: forces in N beside indicator columns.
  const Eigen::VectorXd norms = x.colwise().norm().transpose();
  const Eigen::MatrixXd scaled = x * norms.cwiseInverse().asDiagonal();
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(scaled);
  const int p = static_cast<int>(x.cols());
  const Eigen::MatrixXd upper =
      qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd upper_inverse =
      upper.triangularView<Eigen::Upper>().solve(
          Eigen::MatrixXd::Identity(p, p));
  r.beta = norms.cwiseInverse().asDiagonal() * qr.solve(y);
  r.inverse_normal = norms.cwiseInverse().asDiagonal() * upper_inverse *
                     upper_inverse.transpose() *
                     norms.cwiseInverse().asDiagonal();
  r.rss = (x * r.beta - y).squaredNorm();
  return r;
}

// Fits of one channel `c` of `response` (one entry per log sample).
ChannelFigures FitChannel(const RunSamples& s,
                          const std::vector<Vec6<double>>& response, int c,
                          double sigma) {
  ChannelFigures figures;
  const bool has_falling = !s.index[kFalling].empty();
  const int n_rise = static_cast<int>(s.index[kRising].size());
  const int n = n_rise + static_cast<int>(s.index[kFalling].size());
  // Common gradient, one intercept per branch: [1_rise, 1_fall, f].
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n, has_falling ? 3 : 2);
  Eigen::VectorXd y(n);
  for (int b = 0, row = 0; b < kNumBranches; ++b) {
    for (int j : s.index[b]) {
      x(row, b) = 1;
      x(row, x.cols() - 1) = s.f[j];
      y(row++) = response[j](c);
    }
  }
  const Regression joint = Regress(x, y);
  const int g = static_cast<int>(x.cols()) - 1;
  figures.gradient = {joint.beta(g), joint.Se(g), joint.NoiseSe(g, sigma)};
  if (has_falling) {
    Eigen::Vector3d w(-1, 1, 0);  // falling - rising intercept
    const double var = w.dot(joint.inverse_normal * w);
    const int dof = joint.n - 3;
    figures.loop_width = {joint.beta(1) - joint.beta(0),
                          dof > 0 ? std::sqrt(joint.rss / dof * var) : 0.0,
                          sigma * std::sqrt(var)};
  }
  for (int b = 0; b < kNumBranches; ++b) {
    const std::vector<int>& index = s.index[b];
    if (index.size() < 3) continue;
    Eigen::MatrixXd xb(index.size(), 2);
    Eigen::VectorXd yb(index.size());
    double area = 0;
    for (size_t k = 0; k < index.size(); ++k) {
      xb(k, 0) = 1;
      xb(k, 1) = s.f[index[k]];
      yb(k) = response[index[k]](c);
      if (k > 0) {
        area += 0.5 * (yb(k) + yb(k - 1)) * (xb(k, 1) - xb(k - 1, 1));
      }
    }
    figures.loop_area -= area;
    // The loop is closed by straight segments between the branches' ends
    // (across the hold, and back to the start).
    if (b == kFalling) {
      const int last_rise = s.index[kRising].back();
      const int first_fall = index.front(), last_fall = index.back();
      const int first_rise = s.index[kRising].front();
      for (const auto& [from, to] : {std::pair{last_rise, first_fall},
                                     std::pair{last_fall, first_rise}}) {
        figures.loop_area -=
            0.5 * (response[from](c) + response[to](c)) * (s.f[to] - s.f[from]);
      }
    }
    const Regression line = Regress(xb, yb);
    LineFit& fit = b == kRising ? figures.rising : figures.falling;
    fit = {line.beta(1),
           line.beta(0),
           line.Se(1),
           line.NoiseSe(1, sigma),
           static_cast<int>(index.size()),
           std::sqrt(line.rss / static_cast<double>(index.size()))};
  }
  if (!has_falling) figures.loop_area = 0;
  return figures;
}

std::array<ChannelFigures, 6> FitChannels(
    const RunSamples& s, const std::vector<Vec6<double>>& response,
    const Vec6<double>& sigma) {
  std::array<ChannelFigures, 6> channels;
  for (int c = 0; c < 6; ++c)
    channels[c] = FitChannel(s, response, c, sigma(c));
  return channels;
}

// The model's sensor readings of one experiment, with the value of
// uncertain parameter `perturbed` (-1: none) moved by `delta`.
// The index in `model`'s parameters of the effect parameter called
// "effect.parameter", or -1.
int EffectParameterIndex(const EffectModel& model, const std::string& name) {
  for (int i = kNumBushings; i < model.num_parameters(); ++i) {
    const EffectParameter& p = model.parameters()[i];
    if (p.effect + "." + p.name == name) return i;
  }
  return -1;
}

// A model's stiffness bounds do not matter for a simulation.
Status CreateModel(const SuspensionParameters<double>& parameters,
                   const std::vector<std::string>& effects,
                   EffectModel* model) {
  return EffectModel::Create(parameters, effects, 0.01, 100.0, model);
}

// The value of uncertain parameter `name` in `m`.
double UncertainValue(const KcModel& m, const EffectModel& model,
                      const std::string& name) {
  if (const double* value = FindParameter(m.parameters, name)) return *value;
  const int i = EffectParameterIndex(model, name);
  return i >= 0 ? m.effect_values[i - kNumBushings] : 0.0;
}

// The model's sensor readings of one experiment, with the value of
// uncertain parameter `perturbed` (-1: none) moved by `delta`. The model is
// created after the move: its nominal parameters (damping, spring, masses,
// hard points) are what it simulates.
Status SimulateModel(const KcModel& m, int perturbed, double delta,
                     const Experiment& experiment,
                     std::vector<Vec6<double>>* sensed) {
  SuspensionParameters<double> parameters = m.parameters;
  std::vector<double> effect_values = m.effect_values;
  EffectModel model;
  KCRIG_RETURN_IF_ERROR(CreateModel(parameters, m.effects, &model));
  if (perturbed >= 0) {
    const std::string& name = m.uncertain[perturbed];
    if (double* value = FindParameter(&parameters, name)) {
      *value += delta;
      KCRIG_RETURN_IF_ERROR(CreateModel(parameters, m.effects, &model));
    } else {
      const int i = EffectParameterIndex(model, name);
      if (i < 0) {
        return Status::Error("K&C sheet: no parameter \"" + name +
                             "\" in the " + m.name + " model");
      }
      effect_values[i - kNumBushings] += delta;
    }
  }
  std::vector<double> values;
  for (int i = 0; i < kNumBushings; ++i) {
    values.push_back(parameters.bushings[i].stiffness);
  }
  values.insert(values.end(), effect_values.begin(), effect_values.end());
  if (static_cast<int>(values.size()) != model.num_parameters()) {
    return Status::Error("K&C sheet: the " + m.name + " model has " +
                         std::to_string(model.num_parameters() - kNumBushings) +
                         " effect parameters, " +
                         std::to_string(effect_values.size()) + " given");
  }
  return SimulateEffectModel(model, values, experiment, m.integrator_step,
                             sensed);
}

Comparison Compare(const Figure& rig, const Figure& model, double model_se,
                   double flag_z) {
  Comparison c;
  c.difference = model.value - rig.value;
  const double se = std::hypot(rig.noise_standard_error, model_se);
  c.z = se > 0 ? c.difference / se : 0.0;
  c.differs = std::abs(c.z) > flag_z;
  return c;
}

// The model's simulations of one run: at its values (first), then at each
// uncertain parameter moved by +h and -h (h a tenth of its standard error,
// at most 1 % of its value; 0 when it has none).
struct ModelRun {
  std::vector<std::vector<Vec6<double>>> sensed;
  std::vector<double> step;
};

Status SimulateRun(const KcModel& m, const Experiment& logged, ModelRun* run) {
  // The experiment at the model's step, which must divide the sample
  // period.
  Experiment experiment = logged;
  const long steps = std::lround(logged.sample_period / m.integrator_step);
  if (steps < 1 || std::abs(steps * m.integrator_step - logged.sample_period) >
                       1e-9 * logged.sample_period) {
    return Status::Error(logged.source + ": the model's step " +
                         std::to_string(m.integrator_step) +
                         " s does not divide the log's sample period " +
                         std::to_string(logged.sample_period) + " s");
  }
  experiment.steps_per_sample = static_cast<int>(steps);
  const int np = static_cast<int>(m.uncertain.size());
  run->sensed.assign(1 + 2 * np, {});
  run->step.assign(np, 0.0);
  KCRIG_RETURN_IF_ERROR(SimulateModel(m, -1, 0, experiment, &run->sensed[0]));
  EffectModel model;
  KCRIG_RETURN_IF_ERROR(CreateModel(m.parameters, m.effects, &model));
  for (int i = 0; i < np; ++i) {
    // A tenth of a standard error, and at most 1 % of the value: a poorly
    // determined stiffness must not turn negative.
    const double value = std::abs(UncertainValue(m, model, m.uncertain[i]));
    run->step[i] = 0.1 * std::sqrt(std::max(m.covariance(i, i), 0.0));
    if (value > 0) run->step[i] = std::min(run->step[i], 0.01 * value);
    if (run->step[i] == 0) continue;
    for (int k = 0; k < 2; ++k) {
      KCRIG_RETURN_IF_ERROR(
          SimulateModel(m, i, k == 0 ? run->step[i] : -run->step[i], experiment,
                        &run->sensed[1 + 2 * i + k]));
    }
  }
  return Status::Ok();
}

// The standard error that the covariance of `m` gives a figure computed by
// `figure` from each simulation of `run`.
template <typename FigureOf>
double ParameterSe(const KcModel& m, const ModelRun& run, FigureOf figure) {
  const int np = static_cast<int>(m.uncertain.size());
  if (np == 0) return 0;
  Eigen::VectorXd derivative = Eigen::VectorXd::Zero(np);
  for (int i = 0; i < np; ++i) {
    if (run.step[i] == 0) continue;
    derivative(i) =
        (figure(run.sensed[1 + 2 * i]) - figure(run.sensed[2 + 2 * i])) /
        (2 * run.step[i]);
  }
  return std::sqrt(std::max(derivative.dot(m.covariance * derivative), 0.0));
}

// The model's side of one run: its figures on its own simulation, their
// parameter uncertainty, the comparison.
void AddModel(const KcRun& run, const RunSamples& s, const KcModel& m,
              const ModelRun& simulated, const KcSheetOptions& options,
              RunSheet* sheet) {
  const Vec6<double>& sigma = run.experiment->sigma;
  sheet->model = FitChannels(s, simulated.sensed[0], sigma);
  for (int c = 0; c < 6; ++c) {
    sheet->model_gradient_se[c] =
        ParameterSe(m, simulated, [&](const std::vector<Vec6<double>>& r) {
          return FitChannel(s, r, c, sigma(c)).gradient.value;
        });
    sheet->gradient_difference[c] =
        Compare(sheet->rig[c].gradient, sheet->model[c].gradient,
                sheet->model_gradient_se[c], options.flag_z);
    if (!sheet->has_falling) continue;
    sheet->model_loop_width_se[c] =
        ParameterSe(m, simulated, [&](const std::vector<Vec6<double>>& r) {
          return FitChannel(s, r, c, sigma(c)).loop_width.value;
        });
    sheet->loop_width_difference[c] =
        Compare(sheet->rig[c].loop_width, sheet->model[c].loop_width,
                sheet->model_loop_width_se[c], options.flag_z);
  }
}

// Component fits: every (run, branch) its own intercept, a common Fx and
// Fy gradient. Returns false when the runs' directions do not separate
// the components.
struct ComponentRegression {
  Eigen::MatrixXd x;
  std::vector<std::pair<int, int>> rows;  // (run of the group, log sample)
};

bool BuildComponentRegression(const std::vector<const RunSamples*>& samples,
                              const std::vector<const Experiment*>& runs,
                              double max_condition,
                              ComponentRegression* regression) {
  int n = 0, groups = 0;
  for (const RunSamples* s : samples) {
    for (const std::vector<int>& index : s->index) {
      n += static_cast<int>(index.size());
      groups += !index.empty();
    }
  }
  regression->x = Eigen::MatrixXd::Zero(n, groups + 2);
  regression->rows.clear();
  int row = 0, group = 0;
  for (size_t r = 0; r < samples.size(); ++r) {
    for (const std::vector<int>& index : samples[r]->index) {
      if (index.empty()) continue;
      for (int j : index) {
        regression->x(row, group) = 1;
        regression->x(row, groups) = runs[r]->forces[j](0);
        regression->x(row, groups + 1) = runs[r]->forces[j](1);
        regression->rows.push_back({static_cast<int>(r), j});
        ++row;
      }
      ++group;
    }
  }
  // The spread of the force directions once the intercepts are taken out
  // (N^2 in both: no scaling, which would make a direction the runs barely
  // move in look as good as the others).
  const Eigen::MatrixXd normal = regression->x.transpose() * regression->x;
  const Eigen::MatrixXd a = normal.topLeftCorner(groups, groups);
  const Eigen::MatrixXd b = normal.topRightCorner(groups, 2);
  const Eigen::Matrix2d schur =
      normal.bottomRightCorner(2, 2) - b.transpose() * a.ldlt().solve(b);
  const Eigen::Vector2d eigen =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(schur).eigenvalues();
  return eigen(0) > 0 && eigen(1) / eigen(0) < max_condition;
}

Eigen::VectorXd ComponentResponse(
    const ComponentRegression& regression,
    const std::vector<const std::vector<Vec6<double>>*>& responses, int c) {
  Eigen::VectorXd y(regression.rows.size());
  for (size_t k = 0; k < regression.rows.size(); ++k) {
    const auto [run, j] = regression.rows[k];
    y(k) = (*responses[run])[j](c);
  }
  return y;
}

// The component sheet of the runs `members` (indices into `runs`), or
// false when their directions do not separate Fx from Fy.
bool ComputeComponents(const std::vector<KcRun>& runs,
                       const std::vector<RunSamples>& samples,
                       const std::vector<ModelRun>& simulated,
                       const KcModel* model, const std::vector<int>& members,
                       const KcSheet& sheet, const KcSheetOptions& options,
                       ComponentSheet* component) {
  std::vector<const RunSamples*> group_samples;
  std::vector<const Experiment*> experiments;
  std::vector<const std::vector<Vec6<double>>*> measured, modelled;
  for (int r : members) {
    group_samples.push_back(&samples[r]);
    experiments.push_back(runs[r].experiment);
    measured.push_back(&runs[r].experiment->measured);
    if (model != nullptr) modelled.push_back(&simulated[r].sensed[0]);
    component->sources.push_back(runs[r].experiment->source);
  }
  ComponentRegression regression;
  if (!BuildComponentRegression(group_samples, experiments,
                                options.max_component_condition, &regression)) {
    return false;
  }
  const int fx = static_cast<int>(regression.x.cols()) - 2;
  component->z_a = runs[members[0]].experiment->z_a;
  for (int c = 0; c < 6; ++c) {
    const double sigma = runs[members[0]].experiment->sigma(c);
    const Regression rig =
        Regress(regression.x, ComponentResponse(regression, measured, c));
    for (int k = 0; k < 2; ++k) {
      component->rig(c, k) = rig.beta(fx + k);
      component->rig_se(c, k) = rig.Se(fx + k);
      component->rig_noise_se(c, k) = rig.NoiseSe(fx + k, sigma);
    }
    if (model == nullptr) continue;
    const Regression fit =
        Regress(regression.x, ComponentResponse(regression, modelled, c));
    for (int k = 0; k < 2; ++k) {
      component->model(c, k) = fit.beta(fx + k);
      // The parameter uncertainty of a component gradient, through the
      // simulations of every member run.
      const int np = static_cast<int>(model->uncertain.size());
      Eigen::VectorXd derivative = Eigen::VectorXd::Zero(np);
      for (int i = 0; i < np; ++i) {
        const double h = simulated[members[0]].step[i];
        if (h == 0) continue;
        std::array<double, 2> side{};
        for (int sign = 0; sign < 2; ++sign) {
          std::vector<const std::vector<Vec6<double>>*> moved;
          for (int r : members) {
            moved.push_back(&simulated[r].sensed[1 + 2 * i + sign]);
          }
          side[sign] =
              Regress(regression.x, ComponentResponse(regression, moved, c))
                  .beta(fx + k);
        }
        derivative(i) = (side[0] - side[1]) / (2 * h);
      }
      component->model_se(c, k) = std::sqrt(std::max(
          np > 0 ? derivative.dot(model->covariance * derivative) : 0.0, 0.0));
      const double se =
          std::hypot(component->rig_noise_se(c, k), component->model_se(c, k));
      component->z(c, k) =
          se > 0 ? (component->model(c, k) - component->rig(c, k)) / se : 0.0;
    }
  }
  if (model != nullptr) {
    for (int k = 0; k < 2; ++k) {
      const Vec6<double> g = StaticGradient(
          sheet.compliance, Vec3<double>::Unit(k), component->z_a);
      component->static_compliance.col(k) = g;
    }
  }
  return true;
}

// Sign flips of SAE J670 against ISO 8855: of the channels (x, y, z, toe,
// camber, caster) and of the loads (Fx, Fy, Fz, Mx, My, Mz).
const Vec6<double> kSaeChannel =
    (Vec6<double>() << 1, -1, -1, -1, 1, -1).finished();
const Vec6<double> kSaeLoad =
    (Vec6<double>() << 1, -1, -1, 1, -1, -1).finished();

void FlipChannel(double sign, ChannelFigures* f) {
  f->gradient.value *= sign;
  f->rising.slope *= sign;
  f->rising.intercept *= sign;
  f->falling.slope *= sign;
  f->falling.intercept *= sign;
  f->loop_width.value *= sign;
  f->loop_area *= sign;
}

// The sheet in SAE axes: a gradient along the excitation is a ratio of a
// channel to a scalar force level, so only the channel's sign moves; a
// component gradient or compliance takes both signs.
void ToSae(KcSheet* sheet) {
  for (RunSheet& r : sheet->runs) {
    r.phi = -r.phi;
    r.z_a = -r.z_a;
    for (Vec6<double>& y : r.model_response) y = y.cwiseProduct(kSaeChannel);
    for (int c = 0; c < 6; ++c) {
      FlipChannel(kSaeChannel(c), &r.rig[c]);
      FlipChannel(kSaeChannel(c), &r.model[c]);
      r.gradient_difference[c].difference *= kSaeChannel(c);
      r.gradient_difference[c].z *= kSaeChannel(c);
      r.loop_width_difference[c].difference *= kSaeChannel(c);
      r.loop_width_difference[c].z *= kSaeChannel(c);
      r.static_gradient[c] *= kSaeChannel(c);
    }
  }
  const Eigen::Matrix<double, 6, 2> sign =
      kSaeChannel * kSaeLoad.head<2>().transpose();
  for (ComponentSheet& c : sheet->components) {
    c.z_a = -c.z_a;
    c.rig = c.rig.cwiseProduct(sign);
    c.model = c.model.cwiseProduct(sign);
    c.z = c.z.cwiseProduct(sign);
    c.static_compliance = c.static_compliance.cwiseProduct(sign);
  }
  const Mat6<double> full = kSaeChannel * kSaeLoad.transpose();
  StaticCompliance& k = sheet->compliance;
  k.rest = k.rest.cwiseProduct(kSaeChannel);
  k.wheel_centre = k.wheel_centre.cwiseProduct(full);
  k.contact_patch = k.contact_patch.cwiseProduct(full);
  k.contact_patch_z = -k.contact_patch_z;
}

struct NamedDefinition {
  const char* name;
  int channel;  // row: x, y, z, toe, camber, caster
  int load;     // column: Fx, Fy, Fz, Mx, My, Mz
};
constexpr NamedDefinition kNamed[] = {
    {"lateral force steer", 3, 1},      {"lateral force camber", 4, 1},
    {"lateral compliance", 1, 1},       {"longitudinal compliance", 0, 0},
    {"longitudinal force steer", 3, 0}, {"aligning torque steer", 3, 5},
};

// A compliance entry in display units: mm or deg per kN, or per 100 N m
// for a moment (aligning torque steer is read so).
double NamedDisplay(int channel, int load, double si) {
  return ChannelDisplayValue(channel, si) * (load < 3 ? 1e3 : 1e2);
}

std::string NamedUnit(int channel, int load) {
  return std::string(ChannelDisplayUnit(channel)) +
         (load < 3 ? "/kN" : "/100 N m");
}

std::string HeightPlace(double z_a) {
  char text[40];
  std::snprintf(text, sizeof text, "z_a %.3f m", z_a);
  return text;
}

// The standard figures: the rig's from each component sheet, with the
// model's static compliance at the same height; the model's alone at the
// wheel centre and the contact patch.
void AddNamedFigures(KcSheet* sheet) {
  for (const ComponentSheet& c : sheet->components) {
    for (const NamedDefinition& d : kNamed) {
      if (d.load > 1) continue;
      NamedFigure f{d.name, HeightPlace(c.z_a), NamedUnit(d.channel, d.load)};
      f.has_rig = true;
      f.rig = NamedDisplay(d.channel, d.load, c.rig(d.channel, d.load));
      f.rig_standard_error =
          NamedDisplay(d.channel, d.load, c.rig_se(d.channel, d.load));
      f.has_model = sheet->has_model;
      f.model = NamedDisplay(d.channel, d.load, c.model(d.channel, d.load));
      f.model_standard_error =
          NamedDisplay(d.channel, d.load, c.model_se(d.channel, d.load));
      f.z = c.z(d.channel, d.load);
      f.model_static = NamedDisplay(d.channel, d.load,
                                    c.static_compliance(d.channel, d.load));
      sheet->named.push_back(f);
    }
  }
  if (!sheet->has_model) return;
  for (int place = 0; place < (sheet->has_contact_patch ? 2 : 1); ++place) {
    const Mat6<double>& m = place == 0 ? sheet->compliance.wheel_centre
                                       : sheet->compliance.contact_patch;
    for (const NamedDefinition& d : kNamed) {
      NamedFigure f{d.name, place == 0 ? "wheel centre" : "contact patch",
                    NamedUnit(d.channel, d.load)};
      f.model_static = NamedDisplay(d.channel, d.load, m(d.channel, d.load));
      sheet->named.push_back(f);
    }
  }
}

// The effect of a parameter called "effect.parameter" (a freed model
// parameter's, "model_parameter.k_spring", is "model_parameter@k_spring"),
// or "".
std::string EffectOf(const std::string& name) {
  const size_t dot = name.find('.');
  if (dot == std::string::npos) return "";
  const std::string effect = name.substr(0, dot);
  if (effect == kModelParameter) return effect + "@" + name.substr(dot + 1);
  for (std::string_view known : kEffectNames) {
    if (effect == known) return effect;
  }
  return "";
}

}  // namespace

Status KcModelOfEstimate(const SuspensionParameters<double>& nominal,
                         const std::vector<std::string>& names,
                         const std::vector<double>& values,
                         const Eigen::MatrixXd& covariance,
                         double integrator_step, KcModel* model) {
  *model = KcModel();
  model->parameters = nominal;
  model->integrator_step = integrator_step;
  for (const std::string& name : names) {
    const std::string effect = EffectOf(name);
    if (!effect.empty() &&
        std::find(model->effects.begin(), model->effects.end(), effect) ==
            model->effects.end()) {
      model->effects.push_back(effect);
    }
  }
  EffectModel effects;
  KCRIG_RETURN_IF_ERROR(CreateModel(nominal, model->effects, &effects));
  model->name = effects.Name();
  for (int i = kNumBushings; i < effects.num_parameters(); ++i) {
    model->effect_values.push_back(effects.parameters()[i].initial);
  }
  for (size_t k = 0; k < names.size(); ++k) {
    if (double* value = FindParameter(&model->parameters, names[k])) {
      *value = values[k];
      continue;
    }
    bool found = false;
    for (int i = kNumBushings; i < effects.num_parameters() && !found; ++i) {
      const EffectParameter& p = effects.parameters()[i];
      found = p.FullName() == names[k];
      if (found) model->effect_values[i - kNumBushings] = values[k];
    }
    if (!found) {
      return Status::Error("\"" + names[k] + "\" is not a parameter of the " +
                           model->name + " model");
    }
  }
  // A freed parameter is the model's own (its static compliance too).
  ApplyFreedParameters(names, values, &model->parameters);
  if (covariance.rows() == static_cast<long>(names.size()) &&
      covariance.cols() == covariance.rows() && covariance.allFinite()) {
    model->uncertain = names;
    model->covariance = covariance;
  }
  return Status::Ok();
}

Status ComputeKcSheet(const std::vector<KcRun>& runs, const KcModel* model,
                      const KcSheetOptions& options, KcSheet* sheet) {
  *sheet = KcSheet();
  sheet->has_model = model != nullptr;
  if (model != nullptr) {
    sheet->model_name = model->name;
    const double cp = options.contact_patch_z;
    sheet->has_contact_patch = std::isfinite(cp);
    KCRIG_RETURN_IF_ERROR(ComputeStaticCompliance(
        model->parameters, sheet->has_contact_patch ? cp : 0.0,
        &sheet->compliance));
  }
  std::vector<RunSamples> samples;
  std::vector<ModelRun> simulated(runs.size());
  for (size_t i = 0; i < runs.size(); ++i) {
    const KcRun& run = runs[i];
    samples.push_back(CollectSamples(run));
    RunSamples& s = samples.back();
    RunSheet r;
    r.source = run.experiment->source;
    r.phi = run.log->metadata.excitation.phi;
    r.z_a = run.experiment->z_a;
    r.fmax = run.log->metadata.excitation.fmax;
    if (!(r.fmax > 0 && run.log->metadata.excitation.duration > 0)) {
      return Status::Error(
          r.source +
          ": the log records no excitation (a CAN bus log carries none): "
          "use the run.csv the run wrote beside it");
    }
    if (s.index[kRising].size() < 3) {
      return Status::Error(r.source +
                           ": no ramp to fit (fewer than 3 measured samples "
                           "on the rising branch)");
    }
    const auto [low, high] =
        std::minmax_element(s.index[kRising].begin(), s.index[kRising].end(),
                            [&s](int a, int b) { return s.f[a] < s.f[b]; });
    if (!(s.f[*high] - s.f[*low] > 1.0)) {
      return Status::Error(r.source +
                           ": the force along the excitation does not move "
                           "on the ramp (under 1 N): nothing to fit");
    }
    if (s.index[kFalling].size() < 3) s.index[kFalling].clear();
    r.has_falling = !s.index[kFalling].empty();
    r.rig = FitChannels(s, run.experiment->measured, run.experiment->sigma);
    r.force_along = s.f;
    r.branches = s.index;
    if (model != nullptr) {
      KCRIG_RETURN_IF_ERROR(
          SimulateRun(*model, *run.experiment, &simulated[i]));
      AddModel(run, s, *model, simulated[i], options, &r);
      r.model_response = simulated[i].sensed[0];
      const Vec6<double> g =
          StaticGradient(sheet->compliance, s.direction, r.z_a);
      for (int c = 0; c < 6; ++c) {
        r.static_gradient[c] = g(c);
        sheet->channel_differs[c] = sheet->channel_differs[c] ||
                                    r.gradient_difference[c].differs ||
                                    r.loop_width_difference[c].differs;
      }
    }
    sheet->runs.push_back(r);
  }
  // Runs at one acting height, in order of their first member.
  std::vector<bool> grouped(runs.size(), false);
  for (size_t i = 0; i < runs.size(); ++i) {
    if (grouped[i]) continue;
    std::vector<int> members;
    for (size_t k = i; k < runs.size(); ++k) {
      if (!grouped[k] &&
          std::abs(runs[k].experiment->z_a - runs[i].experiment->z_a) <
              options.same_height) {
        members.push_back(static_cast<int>(k));
        grouped[k] = true;
      }
    }
    ComponentSheet component;
    if (members.size() >= 2 &&
        ComputeComponents(runs, samples, simulated, model, members, *sheet,
                          options, &component)) {
      sheet->components.push_back(component);
    }
  }
  sheet->convention = options.convention;
  sheet->flag_z = options.flag_z;
  if (options.convention == SignConvention::kSae) ToSae(sheet);
  AddNamedFigures(sheet);
  return Status::Ok();
}

}  // namespace kcrig
