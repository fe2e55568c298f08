#include "estimator/effect_model.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "Eigen/QR"
#include "base/parallel_for.h"
#include "ceres/ceres.h"
#include "ceres/jet.h"
#include "estimator/internal/least_squares.h"
#include "estimator/internal/sensitivity_plant.h"
#include "estimator/jacobian_cache.h"
#include "estimator/residual_structure.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/rig_plant.h"

namespace kcrig {
namespace {

// A model parameter freed (model_parameter@name), fitted about its
// configured value: a coordinate within 50 mm (typical 5 mm), a rate, mass
// or inertia within 0.1 .. 10 times (typical a tenth of it). None for an
// unknown name or a rate configured zero (a spring or damper taken out of
// the rig: nothing to scale).
std::vector<EffectParameter> FreedParameter(
    const std::string& name, const SuspensionParameters<double>& nominal) {
  if (IsHardPoint(name)) {
    // A point moved in space: all three coordinates.
    std::vector<EffectParameter> point;
    for (const char* axis : {".x", ".y", ".z"}) {
      for (const EffectParameter& p : FreedParameter(name + axis, nominal)) {
        point.push_back(p);
      }
    }
    return point;
  }
  SuspensionParameters<double> copy = nominal;
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    if (p.name != name) continue;
    const double value = *p.value;
    if (p.unit == "m") {
      return {{kModelParameter,
               name,
               p.unit,
               value,
               0.005,
               value - 0.05,
               value + 0.05,
               value,
               {}}};
    }
    if (!(value > 0)) return {};
    return {{kModelParameter,
             name,
             p.unit,
             value,
             0.1 * value,
             0.1 * value,
             10 * value,
             value,
             {}}};
  }
  return {};
}

// A sensor error on single channels: each channel's offset (named as the
// channel), its gain error `gain_C` and a coupling `C_from_D` from each
// other channel D of its kind (positions into a position, angles into an
// angle): m_C = y_C (1 + gain) + sum coupling y_D + offset.
std::vector<EffectParameter> PlacedSensorParameters(const std::string& target) {
  SensorChannels channels{};
  ParseSensorChannels(target, &channels);
  std::vector<EffectParameter> own;
  for (int c = 0; c < 6; ++c) {
    if (!channels[c]) continue;
    const std::string name = kChannelNames[c];
    const bool position = c < 3;
    own.push_back({"sensor_offset",
                   name,
                   position ? "m" : "rad",
                   0,
                   position ? 1e-4 : 2e-4,
                   position ? -0.01 : -0.05,
                   position ? 0.01 : 0.05,
                   0,
                   {0}});
    own.push_back(
        {"sensor_offset", "gain_" + name, "-", 0, 0.01, -0.5, 0.5, 0, {0}});
    for (int d = position ? 0 : 3; d < (position ? 3 : 6); ++d) {
      if (d == c) continue;
      own.push_back({"sensor_offset",
                     name + "_from_" + kChannelNames[d],
                     "-",
                     0,
                     0.01,
                     -0.5,
                     0.5,
                     0,
                     {0}});
    }
  }
  return own;
}

// The fitted parameters of each effect. Bounds keep the plant well posed
// (a Dahl force or lag constant of zero divides by zero) and physically
// plausible; the start is the "no effect" end of each range, or, where that
// end is degenerate, a small value of the effect.
std::vector<EffectParameter> ParametersOf(
    const std::string& effect, const std::string& target,
    const SuspensionParameters<double>& nominal) {
  if (effect == kModelParameter) return FreedParameter(target, nominal);
  if (effect == "bushing_damping") {
    // Starts at the model's own bushing damping: no change.
    double model_damping = 0;
    for (const AxialElement<double>& b : nominal.bushings) {
      model_damping += b.damping / static_cast<double>(kNumBushings);
    }
    return {{effect, "d", "N s/m", 0, 3e5, 0, 1e7, model_damping, {1e6}}};
  }
  if (effect == "hysteresis") {
    // The third start, a large force on a soft loop, reaches large
    // effects that the others leave in a Coulomb-like minimum (sigma at
    // its upper bound, a third of the force).
    return {{effect, "force", "N", 0, 400, 1, 5000, 50, {300, 1000}},
            {effect, "sigma", "N/m", 0, 4e7, 1e6, 1e9, 4e7, {4e7, 1e7}, true}};
  }
  if (effect == "progressive_stiffness") {
    // Symmetric (c3 d^3, c2 |d| d) and asymmetric (a2 d^2) stiffening:
    // rubber often stiffens more one way than the other.
    return {{effect, "c3", "N/m^3", 0, 4e11, -2e13, 2e13, 0, {0}},
            {effect, "c2", "N/m^2", 0, 1e10, -1e12, 1e12, 0, {0}},
            {effect, "a2", "N/m^2", 0, 1e10, -1e12, 1e12, 0, {0}}};
  }
  if (effect == "actuator_lag") {
    return {{effect, "tau", "s", 0, 0.05, 2e-4, 0.5, 0.005, {0.03}},
            {effect, "dead_time", "s", 0, 0.01, 0, 0.1, 0.002, {0.005}}};
  }
  if (effect == "rig_compliance") {
    // Fitted as the compliance 1/k, linear in the sensed position. Its
    // range crosses zero (no mount give) so that a rig without the effect
    // is an interior point, not a bound the fit would crawl to; a negative
    // compliance is unphysical and says "no effect" within the noise.
    FixtureAxes axes = kTranslationalAxes;
    if (!target.empty()) ParseFixtureAxes(target, &axes);
    std::vector<EffectParameter> own;
    if (axes[0] || axes[1] || axes[2]) {
      own.push_back(
          {effect, "compliance", "m/N", 0, 2e-8, -1e-6, 1e-6, 1e-10, {1e-10}});
    }
    if (axes[3] || axes[4]) {
      own.push_back({effect,
                     "rotational_compliance",
                     "rad/(N m)",
                     0,
                     2e-6,
                     -1e-4,
                     1e-4,
                     1e-8,
                     {1e-8}});
    }
    return own;
  }
  if (effect == "sensor_offset" && !target.empty()) {
    return PlacedSensorParameters(target);
  }
  if (effect == "sensor_offset") {
    return {{effect, "x", "m", 0, 1e-4, -0.01, 0.01, 0, {0}},
            {effect, "y", "m", 0, 1e-4, -0.01, 0.01, 0, {0}},
            {effect, "z", "m", 0, 1e-4, -0.01, 0.01, 0, {0}},
            {effect, "toe", "rad", 0, 2e-4, -0.05, 0.05, 0, {0}},
            {effect, "camber", "rad", 0, 2e-4, -0.05, 0.05, 0, {0}},
            {effect, "caster", "rad", 0, 2e-4, -0.05, 0.05, 0, {0}},
            {effect, "scale", "-", 1, 0.01, 0.5, 1.5, 1, {1}}};
  }
  return {};
}

template <typename T>
void SetEffectParameter(const EffectParameter& p, const T& value,
                        BasicPlantEffects<T>* e) {
  const std::string& n = p.name;
  if (p.effect == "bushing_damping") {
    e->bushing_damping.enabled = true;
    e->bushing_damping.d = value;
  } else if (p.effect == "hysteresis") {
    e->hysteresis.enabled = true;
    (n == "force" ? e->hysteresis.force : e->hysteresis.sigma) = value;
  } else if (p.effect == "progressive_stiffness") {
    e->progressive_stiffness.enabled = true;
    auto& stiffening = e->progressive_stiffness;
    (n == "c3"   ? stiffening.c3
     : n == "c2" ? stiffening.c2
                 : stiffening.a2) = value;
  } else if (p.effect == "actuator_lag") {
    e->actuator_lag.enabled = true;
    (n == "tau" ? e->actuator_lag.tau : e->actuator_lag.dead_time) = value;
  } else if (p.effect == "rig_compliance") {
    e->rig_compliance.enabled = true;
    (n == "compliance" ? e->rig_compliance.k : e->rig_compliance.k_rot) =
        T(1.0) / value;
  } else if (p.effect == "sensor_offset") {
    e->sensor_offset.enabled = true;
    if (n == "scale") e->sensor_offset.scale = value;
    for (int k = 0; k < 6; ++k) {
      const std::string channel = kChannelNames[k];
      if (n == channel) e->sensor_offset.offset(k) = value;
      if (n == "gain_" + channel) e->sensor_offset.mixing(k, k) = value;
      for (int j = 0; j < 6; ++j) {
        if (n == channel + "_from_" + kChannelNames[j]) {
          e->sensor_offset.mixing(k, j) = value;
        }
      }
    }
  }
}

template <typename T>
bool SimulateSensed(const EffectModel& model, const T* theta,
                    const Experiment& experiment, double step,
                    std::vector<Vec6<T>>* sensed) {
  SuspensionParameters<T> parameters;
  BasicPlantEffects<T> effects;
  model.Build(theta, &parameters, &effects);
  BasicRigPlant<T> plant(parameters, effects, step, model.max_dead_time());
  const std::vector<Vec3<double>>& forces = experiment.forces;
  const SampledLoad<double> load{
      &forces, experiment.sample_period, experiment.z_a,
      experiment.sample_period * (forces.size() - 1)};
  // A rig log starts from what the rig kept of its last run: the tare.
  const Status settled =
      experiment.tare
          ? plant.SettleAtRest(forces[0].cast<T>(), T(experiment.z_a),
                               *experiment.tare, experiment.sigma)
          : plant.Settle(forces[0].cast<T>(), T(experiment.z_a));
  if (!settled.ok()) return false;
  sensed->resize(forces.size());
  (*sensed)[0] = plant.Sensed();
  long step_index = 0;
  for (size_t j = 1; j < forces.size(); ++j) {
    for (int s = 0; s < experiment.steps_per_sample; ++s) {
      plant.Step(load.LoadAt(++step_index * step).force.cast<T>());
    }
    if (!plant.Finite(0.5)) return false;
    (*sensed)[j] = plant.Sensed();
  }
  return true;
}

// The weighted residuals (sensed - measured) / sigma of one experiment over
// all six channels, zero for unobserved samples, with one parameter block
// of size 1 per theta; the Jacobian is exact (a Jet of 8 or 14 directions,
// the unused ones zero). Evaluated inside theta's box only (the problem's).
class EffectResidual : public ceres::CostFunction {
 public:
  EffectResidual(const EffectModel* model, const Experiment* experiment,
                 double step)
      : model_(model), experiment_(experiment), step_(step) {
    for (int i = 0; i < model->num_parameters(); ++i) {
      mutable_parameter_block_sizes()->push_back(1);
    }
    set_num_residuals(static_cast<int>(experiment->measured.size() * 6));
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    std::vector<double> theta(model_->num_parameters());
    for (int i = 0; i < model_->num_parameters(); ++i) {
      theta[i] = parameters[i][0];
    }
    if (jacobians == nullptr) {
      return Fill<double>(theta.data(), residuals, nullptr);
    }
    // Two Jet sizes: a single effect and the pairs of two small ones (at
    // most 5 + 2 + 1 parameters), and the rest. Each size is a whole
    // tangent-linear plant to compile (minutes under the sanitizers), and
    // a padded direction costs little.
    return cache_.Evaluate(
        parameters, model_->num_parameters(), num_residuals(), residuals,
        jacobians, [&](double* all_residuals, double** columns) {
          if (model_->num_parameters() <= SensitivityJet::DIMENSION) {
            return Fill<SensitivityJet>(theta.data(), all_residuals, columns);
          }
          return Fill<ceres::Jet<double, kMaxEffectModelParameters>>(
              theta.data(), all_residuals, columns);
        });
  }

 private:
  // `jacobians[i]`: the column of theta_i, null when not wanted.
  template <typename T>
  bool Fill(const double* theta, double* residuals, double** jacobians) const {
    const int n = model_->num_parameters();
    std::vector<T> seeded(n);
    for (int i = 0; i < n; ++i) {
      seeded[i] = T(theta[i]);
      if constexpr (!std::is_same_v<T, double>) seeded[i].v[i] = 1.0;
    }
    std::vector<Vec6<T>> sensed;
    if (!SimulateSensed(*model_, seeded.data(), *experiment_, step_, &sensed)) {
      return false;
    }
    for (size_t j = 0; j < sensed.size(); ++j) {
      const bool seen = Observed(*experiment_, j);
      for (int k = 0; k < 6; ++k) {
        const size_t row = j * 6 + k;
        const double inverse_sigma = seen ? 1.0 / experiment_->sigma(k) : 0.0;
        residuals[row] = (ValueOf(sensed[j](k)) - experiment_->measured[j](k)) *
                         inverse_sigma;
        if constexpr (!std::is_same_v<T, double>) {
          for (int i = 0; i < n; ++i) {
            if (jacobians[i] != nullptr) {
              jacobians[i][row] = sensed[j](k).v[i] * inverse_sigma;
            }
          }
        }
      }
    }
    return true;
  }

  const EffectModel* model_;
  const Experiment* experiment_;
  double step_;
  // The Jacobian Ceres evaluated last, for the uncertainty analysis.
  mutable JacobianCache cache_;
};

// The box of the scaled parameters theta.
void ThetaBox(const EffectModel& model, std::vector<double>* lower,
              std::vector<double>* upper) {
  lower->clear();
  upper->clear();
  for (int i = 0; i < model.num_parameters(); ++i) {
    lower->push_back(model.ToTheta(i, model.parameters()[i].lower));
    upper->push_back(model.ToTheta(i, model.parameters()[i].upper));
  }
}

// A candidate's fit to `experiments` in theta on `lower` .. `upper`.
class EffectProblem : public LeastSquaresProblem {
 public:
  EffectProblem(const EffectModel& model,
                const std::vector<Experiment>& experiments, double step,
                const std::vector<double>& lower,
                const std::vector<double>& upper)
      : LeastSquaresProblem(lower, upper) {
    for (const Experiment& e : experiments) {
      AddResidualBlock(new EffectResidual(&model, &e, step));
    }
  }
};

}  // namespace

namespace {

// Effects are joined by '+', and so are a placement's components: a part
// that names a component continues the effect before it.
std::vector<std::string> SplitModelName(const std::string& name) {
  std::vector<std::string> effects;
  if (name == "nominal") return effects;
  for (size_t begin = 0;;) {
    const size_t end = name.find('+', begin);
    const std::string part = name.substr(begin, end - begin);
    const bool component = part.rfind(kBushingComponent, 0) == 0 ||
                           part.rfind(kFixtureComponent, 0) == 0 ||
                           part.rfind(kActuatorComponent, 0) == 0 ||
                           part.rfind(kSensorComponent, 0) == 0;
    if (component && !effects.empty()) {
      effects.back() += "+" + part;
    } else {
      effects.push_back(part);
    }
    if (end == std::string::npos) break;
    begin = end + 1;
  }
  return effects;
}

// "hysteresis@bushing:V1" into its class and place (every bushing when
// unplaced; only bushing effects are placed), "model_parameter@k_spring"
// into its class and the parameter it frees.
Status ParsePlacedEffect(const std::string& effect, std::string* name,
                         BushingSet* at, std::string* target) {
  const size_t separator = effect.find('@');
  *name = effect.substr(0, separator);
  *at = kEveryBushing;
  target->clear();
  if (*name == kModelParameter) {
    if (separator == std::string::npos) {
      return Status::Error(
          "model_parameter needs the parameter it frees, e.g. "
          "model_parameter@k_spring");
    }
    *target = effect.substr(separator + 1);
    if (target->empty()) {
      return Status::Error("model_parameter@ needs the parameter it frees");
    }
    if (target->find('@') != std::string::npos) {
      return Status::Error("model_parameter is not placed on components");
    }
    const std::vector<std::string> freeable = FreeableModelParameters();
    const bool coordinate = target->find('.') != std::string::npos &&
                            !ComponentOfParameter(*target).empty();
    if (!coordinate && std::find(freeable.begin(), freeable.end(), *target) ==
                           freeable.end()) {
      return Status::Error("'" + *target +
                           "' is not a model parameter a diagnosis frees "
                           "(k_spring, d_damper, mass, Jxx, Jyy, Jzz, a "
                           "hard point such as O1 or one of its coordinates "
                           "such as O1.z)");
    }
    return Status::Ok();
  }
  if (separator == std::string::npos) return Status::Ok();
  const std::string place = effect.substr(separator + 1);
  // A place that is the global form's is the global form: one name per
  // model.
  if (*name == "rig_compliance") {
    FixtureAxes axes;
    KCRIG_RETURN_IF_ERROR(ParseFixtureAxes(place, &axes));
    if (axes != kTranslationalAxes) *target = DescribeFixtureAxes(axes);
    return Status::Ok();
  }
  if (*name == "actuator_lag") {
    ActuatorAxes axes;
    KCRIG_RETURN_IF_ERROR(ParseActuatorAxes(place, &axes));
    if (axes != kEveryActuator) *target = DescribeActuatorAxes(axes);
    return Status::Ok();
  }
  if (*name == "sensor_offset") {
    SensorChannels channels;
    KCRIG_RETURN_IF_ERROR(ParseSensorChannels(place, &channels));
    *target = DescribeSensorChannels(channels);
    return Status::Ok();
  }
  if (!IsBushingEffect(*name)) {
    return Status::Error(
        "bushing_damping, hysteresis and progressive_stiffness are placed on "
        "bushings, rig_compliance on fixture axes, actuator_lag on actuator "
        "axes, sensor_offset on sensor channels; " +
        *name + " is not placed");
  }
  return ParseBushingSet(place, at);
}

}  // namespace

Status EffectModel::Create(const SuspensionParameters<double>& nominal,
                           const std::vector<std::string>& effects,
                           double lower_scale, double upper_scale,
                           EffectModel* model) {
  EffectModel m;
  m.nominal_ = nominal;
  for (const std::string& effect : effects) {
    const Status status = ParsePlacedEffect(effect, &m.effects_.emplace_back(),
                                            &m.placements_.emplace_back(),
                                            &m.targets_.emplace_back());
    if (!status.ok()) {
      return Status::Error("'" + effect + "': " + status.message());
    }
    const std::string& target = m.targets_.back();
    if (m.effects_.back() == "rig_compliance" && !target.empty()) {
      ParseFixtureAxes(target, &m.fixture_axes_);
    }
    if (m.effects_.back() == "actuator_lag" && !target.empty()) {
      ParseActuatorAxes(target, &m.actuator_axes_);
    }
  }
  const long plant_effects =
      std::count_if(m.effects_.begin(), m.effects_.end(),
                    [](const std::string& e) { return e != kModelParameter; });
  if (plant_effects > 2) {
    return Status::Error("a candidate model combines at most two effects");
  }
  for (int i = 0; i < kNumBushings; ++i) {
    const double c = nominal.bushings[i].stiffness;
    m.parameters_.push_back({"",
                             "c_" + std::string(kBushingChassisNames[i]),
                             "N/m",
                             0,
                             c,
                             lower_scale * c,
                             upper_scale * c,
                             c,
                             {c}});
  }
  for (size_t e = 0; e < m.effects_.size(); ++e) {
    for (size_t before = 0; before < e; ++before) {
      // One form per effect; model parameters differ by what they free (a
      // point frees its coordinates).
      auto point_of = [](const std::string& t) {
        return t.substr(0, t.find('.'));
      };
      if (m.effects_[before] == m.effects_[e] &&
          (m.effects_[e] != kModelParameter ||
           m.targets_[before] == m.targets_[e] ||
           (IsHardPoint(point_of(m.targets_[e])) &&
            point_of(m.targets_[before]) == point_of(m.targets_[e]) &&
            (IsHardPoint(m.targets_[e]) || IsHardPoint(m.targets_[before]))))) {
        return Status::Error("effect '" + effects[e] + "' given twice");
      }
    }
    const std::vector<EffectParameter> own =
        ParametersOf(m.effects_[e], m.targets_[e], nominal);
    if (own.empty() && m.effects_[e] == kModelParameter) {
      return Status::Error("'" + effects[e] + "': the configured " +
                           m.targets_[e] +
                           " is zero: a rate taken out is not freed");
    }
    if (own.empty()) {
      return Status::Error("unknown effect '" + m.effects_[e] + "'");
    }
    for (const EffectParameter& p : own) {
      if (p.name == "dead_time") m.max_dead_time_ = p.upper;
    }
    m.parameters_.insert(m.parameters_.end(), own.begin(), own.end());
  }
  if (m.num_parameters() > kMaxEffectModelParameters) {
    return Status::Error("a candidate model has at most " +
                         std::to_string(kMaxEffectModelParameters) +
                         " parameters");
  }
  *model = std::move(m);
  return Status::Ok();
}

int EffectModel::num_starts() const {
  size_t longest = 0;
  for (const EffectParameter& p : parameters_) {
    longest = std::max(longest, p.later_starts.size());
  }
  return 1 + static_cast<int>(longest);
}

std::vector<double> EffectModel::LaterStart(int k) const {
  std::vector<double> start;
  for (const EffectParameter& p : parameters_) {
    const std::vector<double>& later = p.later_starts;
    start.push_back(later.empty()
                        ? p.initial
                        : later[std::min<size_t>(k - 1, later.size() - 1)]);
  }
  return start;
}

std::vector<double> EffectModel::StartFrom(
    const EffectModel& other, const std::vector<double>& values) const {
  std::vector<double> start;
  for (const EffectParameter& p : parameters_) {
    start.push_back(p.initial);
    for (int i = 0; i < other.num_parameters() && i < (int)values.size(); ++i) {
      if (other.parameters()[i].FullName() == p.FullName()) {
        start.back() = values[i];
      }
    }
  }
  return start;
}

std::vector<std::string> PlaceableComponents(std::string_view effect) {
  std::vector<std::string> components;
  if (IsBushingEffect(effect)) {
    for (std::string_view b : kBushingChassisNames) {
      components.push_back(std::string(kBushingComponent) + std::string(b));
    }
  } else if (effect == "rig_compliance") {
    for (std::string_view axis : kFixtureAxisNames) {
      components.push_back(std::string(kFixtureComponent) + std::string(axis));
    }
  } else if (effect == "actuator_lag") {
    for (std::string_view axis : kActuatorAxisNames) {
      components.push_back(std::string(kActuatorComponent) + std::string(axis));
    }
  } else if (effect == "sensor_offset") {
    for (const char* channel : kChannelNames) {
      components.push_back(std::string(kSensorComponent) + channel);
    }
  }
  return components;
}

bool LoadsComponent(const std::vector<Experiment>& logs,
                    std::string_view component) {
  const bool fixture = component.rfind(kFixtureComponent, 0) == 0;
  if (!fixture && component.rfind(kActuatorComponent, 0) != 0) return true;
  std::string_view axis = component.substr(
      (fixture ? kFixtureComponent : kActuatorComponent).size());
  // A rotation about x turns under F_y, about y under F_x.
  const bool rotation = axis.size() == 2 && axis[0] == 'r';
  if (rotation) axis = axis[1] == 'x' ? "y" : "x";
  const int k = axis == "x" ? 0 : axis == "y" ? 1 : 2;
  for (const Experiment& log : logs) {
    double largest = 0, along = 0;
    for (const Vec3<double>& f : log.forces) {
      largest = std::max(largest, f.cwiseAbs().maxCoeff());
      along = std::max(along, std::abs(f(k)));
    }
    if (along > 0.01 * largest && (!rotation || log.z_a != 0)) return true;
  }
  return false;
}

std::vector<std::string> ModelComponents(const std::string& name) {
  std::vector<std::string> effects, targets, components;
  std::vector<BushingSet> places;
  if (!ParseModelName(name, &effects, &places, &targets).ok()) return {};
  auto add = [&components](const std::string& c) {
    if (!c.empty() && std::find(components.begin(), components.end(), c) ==
                          components.end()) {
      components.push_back(c);
    }
  };
  for (size_t e = 0; e < effects.size(); ++e) {
    std::string text;
    if (IsBushingEffect(effects[e])) {
      text = DescribeBushingSet(places[e]);
    } else if (effects[e] == kModelParameter) {
      text = ComponentOfParameter(targets[e]);
    } else if (effects[e] == "rig_compliance") {
      text = targets[e].empty() ? DescribeFixtureAxes(kTranslationalAxes)
                                : targets[e];
    } else if (effects[e] == "actuator_lag") {
      text = targets[e].empty() ? DescribeActuatorAxes(kEveryActuator)
                                : targets[e];
    } else if (effects[e] == "sensor_offset") {
      text = targets[e].empty()
                 ? DescribeSensorChannels({true, true, true, true, true, true})
                 : targets[e];
    }
    for (size_t begin = 0; begin < text.size();) {
      const size_t end = std::min(text.find('+', begin), text.size());
      add(text.substr(begin, end - begin));
      begin = end + 1;
    }
  }
  // The places in their vocabulary's order (bushings, fixture, actuators,
  // sensors), then the freed parameters' components.
  std::vector<std::string> order;
  for (std::string_view effect :
       {"hysteresis", "rig_compliance", "actuator_lag", "sensor_offset"}) {
    const std::vector<std::string> own = PlaceableComponents(effect);
    order.insert(order.end(), own.begin(), own.end());
  }
  auto rank = [&order](const std::string& c) {
    return std::find(order.begin(), order.end(), c) - order.begin();
  };
  std::stable_sort(components.begin(), components.end(),
                   [&rank](const std::string& a, const std::string& b) {
                     return rank(a) < rank(b);
                   });
  return components;
}

Status EffectModel::CreateNamed(const SuspensionParameters<double>& nominal,
                                const std::string& name, double lower_scale,
                                double upper_scale, EffectModel* model) {
  return Create(nominal, SplitModelName(name), lower_scale, upper_scale, model);
}

Status ParseModelName(const std::string& name,
                      std::vector<std::string>* effects,
                      std::vector<BushingSet>* placements,
                      std::vector<std::string>* targets) {
  effects->clear();
  placements->clear();
  std::vector<std::string> own_targets;
  if (targets == nullptr) targets = &own_targets;
  targets->clear();
  for (const std::string& effect : SplitModelName(name)) {
    KCRIG_RETURN_IF_ERROR(ParsePlacedEffect(effect, &effects->emplace_back(),
                                            &placements->emplace_back(),
                                            &targets->emplace_back()));
  }
  return Status::Ok();
}

std::vector<std::string> EffectModel::EffectNames() const {
  std::vector<std::string> names;
  for (size_t e = 0; e < effects_.size(); ++e) {
    names.push_back(effects_[e]);
    if (!targets_[e].empty()) names.back() += "@" + targets_[e];
    if (placements_[e] != kEveryBushing) {
      names.back() += "@" + DescribeBushingSet(placements_[e]);
    }
  }
  return names;
}

std::string EffectModel::Name() const {
  if (effects_.empty()) return "nominal";
  std::string name;
  for (const std::string& effect : EffectNames()) {
    name += (name.empty() ? "" : "+") + effect;
  }
  return name;
}

template <typename T>
void EffectModel::Build(const T* theta, SuspensionParameters<T>* parameters,
                        BasicPlantEffects<T>* effects) const {
  *parameters = nominal_.Cast<T>();
  *effects = BasicPlantEffects<T>();
  // A sensor error on single channels leaves the others exact.
  effects->sensor_offset.offset.setZero();
  effects->sensor_offset.scale = T(1);
  for (int i = 0; i < num_parameters(); ++i) {
    const EffectParameter& p = parameters_[i];
    const T value = T(p.base) + theta[i] * p.scale;
    if (i < kNumBushings) {
      parameters->bushings[i].stiffness = value;
    } else if (p.effect == kModelParameter) {
      *FindParameter(parameters, p.name) = value;
    } else {
      SetEffectParameter(p, value, effects);
    }
  }
  for (size_t e = 0; e < effects_.size(); ++e) {
    if (BushingSet* at = PlacementOf(effects_[e], effects)) {
      *at = placements_[e];
    }
    if (effects_[e] == "rig_compliance") {
      effects->rig_compliance.at = fixture_axes_;
    }
    if (effects_[e] == "actuator_lag") {
      effects->actuator_lag.at = actuator_axes_;
    }
  }
}
template void EffectModel::Build<double>(const double*,
                                         SuspensionParameters<double>*,
                                         BasicPlantEffects<double>*) const;

Status SimulateEffectModel(const EffectModel& model,
                           const std::vector<double>& values,
                           const Experiment& experiment, double integrator_step,
                           std::vector<Vec6<double>>* sensed) {
  if (static_cast<int>(values.size()) != model.num_parameters()) {
    return Status::Error("one value per parameter of " + model.Name() +
                         " is needed");
  }
  std::vector<double> theta(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    theta[i] = model.ToTheta(static_cast<int>(i), values[i]);
  }
  if (!SimulateSensed(model, theta.data(), experiment, integrator_step,
                      sensed)) {
    return Status::Error(experiment.source + ": the " + model.Name() +
                         " model diverges at the fitted parameters");
  }
  return Status::Ok();
}

Status WeightedJacobian(const EffectModel& model,
                        const std::vector<double>& values,
                        const std::vector<Experiment>& experiments,
                        double integrator_step, std::vector<double>* theta,
                        Eigen::MatrixXd* jacobian, Eigen::VectorXd* residuals) {
  const int n = model.num_parameters();
  if (static_cast<int>(values.size()) != n) {
    return Status::Error("one value per parameter of " + model.Name() +
                         " is needed");
  }
  std::vector<double> lower, upper;
  ThetaBox(model, &lower, &upper);
  theta->resize(n);
  for (int i = 0; i < n; ++i) {
    (*theta)[i] = std::clamp(model.ToTheta(i, values[i]), lower[i], upper[i]);
  }
  long rows = 0;
  for (const Experiment& e : experiments) rows += 6L * e.measured.size();
  jacobian->resize(rows, n);
  residuals->resize(rows);
  std::vector<const double*> parameters(n);
  for (int i = 0; i < n; ++i) parameters[i] = &(*theta)[i];
  std::vector<double*> columns(n);
  long row = 0;
  for (const Experiment& e : experiments) {
    EffectResidual residual(&model, &e, integrator_step);
    for (int i = 0; i < n; ++i) columns[i] = &(*jacobian)(row, i);
    if (!residual.Evaluate(parameters.data(), residuals->data() + row,
                           columns.data())) {
      return Status::Error(e.source + ": the " + model.Name() +
                           " model cannot be evaluated at the fit");
    }
    row += residual.num_residuals();
  }
  return Status::Ok();
}

Status RefitOneStep(const EffectModel& model, const std::vector<double>& values,
                    const std::vector<Experiment>& experiments,
                    double integrator_step, std::vector<double>* refit) {
  std::vector<double> theta;
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd residuals;
  KCRIG_RETURN_IF_ERROR(WeightedJacobian(model, values, experiments,
                                         integrator_step, &theta, &jacobian,
                                         &residuals));
  // The minimum-norm step: directions the data do not determine (a sensor
  // scale against the stiffnesses) do not move.
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> decomposition;
  decomposition.setThreshold(1e-8);
  decomposition.compute(jacobian);
  const Eigen::VectorXd step = decomposition.solve(-residuals);
  std::vector<double> lower, upper;
  ThetaBox(model, &lower, &upper);
  refit->resize(theta.size());
  for (size_t i = 0; i < theta.size(); ++i) {
    const double next = std::isfinite(step(i)) ? theta[i] + step(i) : theta[i];
    (*refit)[i] = model.ToPhysical(i, std::clamp(next, lower[i], upper[i]));
  }
  return Status::Ok();
}

std::vector<std::string> FreeableModelParameters() {
  SuspensionParameters<double> names_only{};
  std::vector<std::string> names;
  for (const NamedParameter<double>& p : ListParameters(&names_only)) {
    // A bushing's stiffness and damping are the bushings' own candidates.
    if (ComponentOfParameter(p.name).rfind(kBushingComponent, 0) == 0) {
      continue;
    }
    // A hard point is freed whole: a point is rarely off along one axis.
    const std::string name = p.name.substr(0, p.name.find('.'));
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      names.push_back(name);
    }
  }
  return names;
}

void ApplyFreedParameters(const std::vector<std::string>& names,
                          const std::vector<double>& values,
                          SuspensionParameters<double>* model) {
  const std::string prefix = kModelParameter + std::string(".");
  for (size_t k = 0; k < names.size() && k < values.size(); ++k) {
    if (names[k].rfind(prefix, 0) != 0) continue;
    if (double* p = FindParameter(model, names[k].substr(prefix.size()))) {
      *p = values[k];
    }
  }
}

namespace {

// ScreenModelParameters for the names one model frees together.
Status ScreenGroup(const SuspensionParameters<double>& nominal,
                   const std::vector<double>& stiffness,
                   const std::vector<std::string>& names,
                   const std::vector<Experiment>& experiments,
                   double integrator_step, std::vector<ParameterLead>* leads) {
  std::vector<std::string> freed;
  for (const std::string& name : names) freed.push_back(FreedModelName(name));
  // Stiffness bounds wide enough for any fit the screening is asked at.
  EffectModel model;
  KCRIG_RETURN_IF_ERROR(EffectModel::Create(nominal, freed, 1e-6, 1e6, &model));
  std::vector<double> values = stiffness;
  for (int i = kNumBushings; i < model.num_parameters(); ++i) {
    values.push_back(model.parameters()[i].base);
  }
  std::vector<double> theta;
  Eigen::MatrixXd jacobian;
  Eigen::VectorXd residuals;
  KCRIG_RETURN_IF_ERROR(WeightedJacobian(model, values, experiments,
                                         integrator_step, &theta, &jacobian,
                                         &residuals));
  // An orthonormal basis of the stiffnesses' columns.
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(
      jacobian.leftCols<kNumBushings>());
  const Eigen::MatrixXd basis =
      qr.householderQ() *
      Eigen::MatrixXd::Identity(jacobian.rows(), kNumBushings);
  int column = kNumBushings;
  for (const std::string& name : names) {
    const int count = static_cast<int>(FreedParameter(name, nominal).size());
    Eigen::MatrixXd own = jacobian.middleCols(column, count);
    column += count;
    own -= basis * (basis.transpose() * own);
    // What the name's columns can take of the residual: its projection on
    // their span (their numerical rank: a point's coordinate the
    // experiments do not see adds nothing).
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> span(own);
    span.setThreshold(1e-10);
    const Eigen::MatrixXd q =
        span.householderQ() * Eigen::MatrixXd::Identity(own.rows(), count);
    const double drop =
        (q.leftCols(span.rank()).transpose() * residuals).squaredNorm();
    leads->push_back({name, std::isfinite(drop) ? drop : 0, count});
  }
  return Status::Ok();
}

}  // namespace

Status ScreenModelParameters(const SuspensionParameters<double>& nominal,
                             const std::vector<double>& stiffness,
                             const std::vector<std::string>& candidates,
                             const std::vector<Experiment>& experiments,
                             double integrator_step, int num_threads,
                             std::vector<ParameterLead>* leads) {
  if (stiffness.size() != kNumBushings) {
    return Status::Error("screening needs the five bushing stiffnesses");
  }
  // Names packed into models of at most kPerModel freed columns each.
  constexpr int kPerModel = kMaxEffectModelParameters - kNumBushings;
  std::vector<std::vector<std::string>> groups;
  std::vector<int> columns_of_group;
  for (const std::string& name : candidates) {
    const int columns = static_cast<int>(FreedParameter(name, nominal).size());
    if (columns == 0) continue;
    if (groups.empty() || columns_of_group.back() + columns > kPerModel) {
      groups.emplace_back();
      columns_of_group.push_back(0);
    }
    groups.back().push_back(name);
    columns_of_group.back() += columns;
  }
  const int num_groups = static_cast<int>(groups.size());
  std::vector<Status> status(num_groups, Status::Ok());
  std::vector<std::vector<ParameterLead>> found(num_groups);
  ParallelFor(num_groups, num_threads, [&](int g) {
    status[g] = ScreenGroup(nominal, stiffness, groups[g], experiments,
                            integrator_step, &found[g]);
  });
  leads->clear();
  for (int g = 0; g < num_groups; ++g) {
    leads->insert(leads->end(), found[g].begin(), found[g].end());
  }
  for (const Status& s : status) KCRIG_RETURN_IF_ERROR(s);
  std::stable_sort(leads->begin(), leads->end(),
                   [](const ParameterLead& a, const ParameterLead& b) {
                     return a.chi2_drop > b.chi2_drop;
                   });
  return Status::Ok();
}

namespace {

// `error` (per log and sample) in the layout of the problem's residual
// vector of `size`: six per sample.
Status StackedError(const EffectModel& model,
                    const std::vector<std::vector<Vec6<double>>>& error,
                    Eigen::Index size, Eigen::VectorXd* stacked) {
  Eigen::Index samples = 0;
  for (const std::vector<Vec6<double>>& log : error) samples += log.size();
  if (6 * samples != size) {
    return Status::Error("the " + model.Name() +
                         " model's residual layout is not per sample");
  }
  stacked->resize(size);
  Eigen::Index at = 0;
  for (const std::vector<Vec6<double>>& log : error) {
    for (const Vec6<double>& e : log) {
      stacked->segment<6>(at) = e;
      at += 6;
    }
  }
  return Status::Ok();
}

// Per experiment, the state the model at `theta` starts from: a rig log's
// tare, and the Dahl forces SettleAtRest finds there.
std::vector<LogInitialState> InitialStates(
    const EffectModel& model, const std::vector<double>& theta,
    const std::vector<Experiment>& experiments, double step) {
  std::vector<LogInitialState> states = InitialStatesAtEquilibrium(experiments);
  SuspensionParameters<double> parameters;
  PlantEffects effects;
  model.Build(theta.data(), &parameters, &effects);
  const bool dahl = effects.hysteresis.enabled;
  const bool creep = effects.bushing_damping.enabled;
  for (size_t k = 0; k < experiments.size(); ++k) {
    const Experiment& e = experiments[k];
    if (!e.tare || !(dahl || creep)) continue;
    LogInitialState& state = states[k];
    state.from_first_row_pose = creep;
    if (!dahl) continue;
    RigPlant plant(parameters, effects, step, model.max_dead_time());
    state.dahl_forces.assign(kNumBushings,
                             std::numeric_limits<double>::quiet_NaN());
    if (plant.SettleAtRest(e.forces[0], e.z_a, *e.tare, e.sigma).ok()) {
      state.dahl_forces.assign(plant.dahl_forces().begin(),
                               plant.dahl_forces().end());
    }
  }
  return states;
}

Status FitAtStep(const EffectModel& model,
                 const std::vector<Experiment>& experiments,
                 const std::vector<double>& initial,
                 const EffectFitOptions& options, double integrator_step,
                 EffectFit* fit) {
  const int n = model.num_parameters();
  if (!initial.empty() && static_cast<int>(initial.size()) != n) {
    return Status::Error("one initial value per parameter of " + model.Name() +
                         " is needed");
  }
  std::vector<double> lower, upper, theta(n);
  ThetaBox(model, &lower, &upper);
  for (int i = 0; i < n; ++i) {
    const EffectParameter& p = model.parameters()[i];
    const double value = initial.empty() ? p.initial : initial[i];
    theta[i] = std::clamp(model.ToTheta(i, value), lower[i], upper[i]);
  }
  EffectProblem problem(model, experiments, integrator_step, lower, upper);
  int observed = 0;
  for (const Experiment& e : experiments) observed += 6 * ObservedCount(e);
  LeastSquaresOptions solver;
  solver.max_iterations = options.max_iterations;
  solver.function_tolerance = options.function_tolerance;
  solver.parameter_tolerance = options.parameter_tolerance;
  solver.gradient_tolerance = 1e-16;
  solver.num_threads = 1;
  solver.stage = "fitting the " + model.Name() + " model";
  solver.callback = options.callback;
  LeastSquaresSummary summary;
  KCRIG_RETURN_IF_ERROR(problem.Minimize(solver, {}, &theta, &summary));

  // The weighted Jacobian at the solution, for the uncertainty.
  double cost = 0;
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  if (!problem.Evaluate(theta, &cost, &residuals, &jacobian)) {
    return Status::Error("the " + model.Name() +
                         " model cannot be evaluated at its fit");
  }

  *fit = EffectFit();
  fit->model = model.Name();
  EstimationResult& result = fit->result;
  result.integrator_step = integrator_step;
  for (int i = 0; i < n; ++i) {
    const EffectParameter& p = model.parameters()[i];
    ParameterEstimate estimate;
    estimate.name = p.FullName();
    estimate.unit = p.unit;
    estimate.nominal = p.scale;
    estimate.initial = model.ToPhysical(i, model.ToTheta(i, p.initial));
    estimate.value = model.ToPhysical(i, theta[i]);
    estimate.at_bound = problem.AtBound(i, theta[i]);
    fit->values.push_back(estimate.value);
    result.parameters.push_back(estimate);
  }
  result.cost = cost;
  result.num_residuals = observed;
  result.memory_rows = MemoryRows(experiments);
  result.initial_states =
      InitialStates(model, theta, experiments, integrator_step);
  result.sigma_hat = observed > n ? std::sqrt(2 * cost / (observed - n)) : 0;
  result.iterations = summary.iterations;
  result.converged = summary.converged;
  result.termination = summary.message;
  std::fill(result.channel_used.begin(), result.channel_used.end(), true);
  const std::vector<std::vector<Vec6<double>>> weighted =
      SplitResiduals(experiments, kAllChannels, residuals);
  result.adequacy = AssessAdequacy(experiments, weighted, kAllChannels, n,
                                   options.uncertainty.adequacy);
  result.residual_rms = ResidualRms(experiments, weighted);
  const ResidualStructure structure =
      MeasureResidualStructure(jacobian, residuals, experiments, 6);
  if (!options.estimate_discretisation) {
    AnalyzeUncertainty(std::move(jacobian), options.uncertainty, &result);
    WidenForResidualStructure(structure, &result);
    return Status::Ok();
  }
  std::vector<std::vector<Vec6<double>>> error;
  KCRIG_RETURN_IF_ERROR(DiscretisationError(model, fit->values, experiments,
                                            integrator_step, &error));
  AddDiscretisationError(experiments, error, &result.adequacy);
  Eigen::VectorXd discretisation;
  KCRIG_RETURN_IF_ERROR(
      StackedError(model, error, residuals.size(), &discretisation));
  const Eigen::VectorXd gradient = jacobian.transpose() * discretisation;
  AnalyzeUncertainty(std::move(jacobian), options.uncertainty, &result);
  WidenForResidualStructure(structure, &result);
  AddDiscretisationBias(gradient, &result);
  return Status::Ok();
}

}  // namespace

Status FitEffectModel(const EffectModel& model,
                      const std::vector<Experiment>& experiments,
                      const std::vector<double>& initial,
                      const EffectFitOptions& options, double integrator_step,
                      EffectFit* fit) {
  const auto start = std::chrono::steady_clock::now();
  KCRIG_RETURN_IF_ERROR(
      FitAtStep(model, experiments, initial, options, integrator_step, fit));
  for (int halving = 1;
       options.estimate_discretisation &&
       halving <= options.max_step_halvings &&
       fit->result.adequacy.discretisation > options.max_discretisation;
       ++halving) {
    const std::vector<double> from = fit->values;
    KCRIG_RETURN_IF_ERROR(
        FitAtStep(model, RefinedExperiments(experiments, 1 << halving), from,
                  options, integrator_step / (1 << halving), fit));
  }
  fit->result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return Status::Ok();
}

Status WeightedResiduals(const EffectModel& model,
                         const std::vector<double>& values, const Experiment& e,
                         double step, std::vector<Vec6<double>>* weighted) {
  std::vector<Vec6<double>> sensed;
  const Status status = SimulateEffectModel(model, values, e, step, &sensed);
  if (!status.ok()) return status;
  *weighted = WeightedResidualsOf(e, sensed);
  return Status::Ok();
}

std::vector<Vec6<double>> WeightedResidualsOf(
    const Experiment& e, const std::vector<Vec6<double>>& sensed) {
  std::vector<Vec6<double>> weighted(sensed.size());
  for (size_t j = 0; j < sensed.size(); ++j) {
    weighted[j] =
        Observed(e, j)
            ? Vec6<double>((sensed[j] - e.measured[j]).cwiseQuotient(e.sigma))
            : Vec6<double>::Zero();
  }
  return weighted;
}

Status DiscretisationError(const EffectModel& model,
                           const std::vector<double>& values,
                           const std::vector<Experiment>& experiments,
                           double step,
                           std::vector<std::vector<Vec6<double>>>* error) {
  error->assign(experiments.size(), {});
  const std::vector<Experiment> finer = RefinedExperiments(experiments, 2);
  for (size_t l = 0; l < experiments.size(); ++l) {
    std::vector<Vec6<double>> at_step, at_half;
    KCRIG_RETURN_IF_ERROR(
        WeightedResiduals(model, values, experiments[l], step, &at_step));
    KCRIG_RETURN_IF_ERROR(
        WeightedResiduals(model, values, finer[l], 0.5 * step, &at_half));
    (*error)[l].resize(at_step.size());
    for (size_t j = 0; j < at_step.size(); ++j) {
      (*error)[l][j] = 2.0 * (at_step[j] - at_half[j]);
    }
  }
  return Status::Ok();
}

Status PredictEffectModel(const EffectModel& model, const EffectFit& fit,
                          const std::vector<Experiment>& given,
                          double given_step, const AdequacyOptions& options,
                          Adequacy* prediction) {
  const int n = model.num_parameters();
  if (static_cast<int>(fit.values.size()) != n ||
      fit.result.information.rows() != n) {
    return Status::Error("the fit does not belong to the " + model.Name() +
                         " model");
  }
  // At the fit's step: the model whose intervals are predicted.
  const int factor =
      fit.result.integrator_step > 0
          ? std::max(1, static_cast<int>(std::lround(
                            given_step / fit.result.integrator_step)))
          : 1;
  const std::vector<Experiment> experiments = RefinedExperiments(given, factor);
  const double integrator_step = given_step / factor;
  std::vector<double> lower, upper, theta(n);
  ThetaBox(model, &lower, &upper);
  for (int i = 0; i < n; ++i) {
    // A value on its bound may round a hair outside it.
    theta[i] = std::clamp(model.ToTheta(i, fit.values[i]), lower[i], upper[i]);
  }
  EffectProblem problem(model, experiments, integrator_step, lower, upper);
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  if (!problem.Evaluate(theta, nullptr, &residuals, &jacobian)) {
    return Status::Error("the " + model.Name() +
                         " model cannot be evaluated at the fit");
  }
  std::vector<std::vector<Vec6<double>>> error;
  KCRIG_RETURN_IF_ERROR(DiscretisationError(model, fit.values, experiments,
                                            integrator_step, &error));
  Eigen::VectorXd discretisation;
  KCRIG_RETURN_IF_ERROR(
      StackedError(model, error, residuals.size(), &discretisation));
  auto assess = [&](const Eigen::VectorXd& r) {
    return AssessPredictionResiduals(experiments, kAllChannels, r, jacobian,
                                     fit.result.information, options);
  };
  *prediction = BetterOfStepAndLimit(assess(residuals),
                                     assess(residuals - discretisation),
                                     experiments, error);
  return Status::Ok();
}

}  // namespace kcrig
