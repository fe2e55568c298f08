// Blind test of `kcrig diagnose`. A generator draws cases from a seed: the
// truth (each of the six library effects, none, or a wrong "known"
// parameter: a hard point off along one axis, or the spring rate), a
// magnitude from small to large,
// the designs of two training logs and one hold-out log, and the noise. It
// writes only the logs, with the truth stripped from their sidecars, runs
// the real CLI on them, and compares the verdict with the truth only after
// diag.json is written. The size of an effect "in the residual" is the RMS,
// in noise units, of the nominal model's residual on the same training
// logs simulated without noise (computed here, never shown to diagnose).
//
// The plant is stepped ten times finer than the model, as a continuous rig
// would be: the model's own discretisation error is part of every case.
//
// The true bushings of every case differ from the configured ones by up to
// +-10 %, as a real rig's do.
//
// Acceptance (issues #7, #19): correct verdict for >= 90 % of the effect
// cases whose effect exceeds 3x the noise; `none` for >= 95 % of the clean
// ones; a wrong parameter beyond 3x the noise named (model_parameter@ it),
// or one of an ambiguous pair, in >= 80 % and never another model with
// high confidence, its true value inside the 95 % interval in >= 90 % of
// those named (asserted with ten or more); >= 80 % of the held-out gap
// closed for the correctly attributed cases. The confusion matrix is
// printed.
//
// KCRIG_BLIND_CASES and KCRIG_BLIND_SEED are compile definitions: the CI
// tier and the full tier are two builds of this file.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "diagnosis/effect_model.h"
#include "emulator/simulated_run.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "rt_core/model/channels.h"
#include "tests/support/cli_runner.h"
#include "tests/support/effect_size.h"
#include "tests/support/temp_dir_test.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

const std::vector<std::string> kClasses = {"bushing_damping",
                                           "hysteresis",
                                           "progressive_stiffness",
                                           "actuator_lag",
                                           "rig_compliance",
                                           "sensor_offset",
                                           "none",
                                           "model_parameter"};

struct Design {
  double phi_deg, z_a, tf, hold, ret;
  std::string Args() const {
    char text[200];
    std::snprintf(text, sizeof(text),
                  "--phi %.3f --z %.4f --duration %.3f --hold %.3f "
                  "--return %.3f",
                  phi_deg, z_a, tf, hold, ret);
    return text;
  }
  RampExcitation<double> Ramp(double fmax) const {
    return {phi_deg * kDegree, z_a, fmax, tf, hold, ret};
  }
};

struct BlindCase {
  std::string truth;      // one of kClasses
  std::string cli_truth;  // --effect ... or --set ...
  double magnitude = 0;   // 0..1, small to large (log scale within a range)
  PlantEffects effects;
  std::vector<std::pair<std::string, double>> sets;
  std::string parameter;  // model_parameter: the one off, and its value
  double parameter_value = 0;
  Design designs[3];  // two training logs, one hold-out
  std::uint64_t seed = 0;
};

double LogUniform(double low, double high, double u) {
  return low * std::pow(high / low, u);
}

BlindCase Draw(int index, std::uint64_t seed,
               const SuspensionParameters<double>& model) {
  std::mt19937_64 rng(seed * 1000003 + index);
  std::uniform_real_distribution<double> u(0, 1);
  BlindCase c;
  c.truth = kClasses[index % kClasses.size()];
  c.magnitude = u(rng);
  c.seed = seed * 1000 + index * 7;
  for (Design& d : c.designs) {
    d = {90 * u(rng), -0.5 * u(rng), 1 + 1.5 * u(rng), 0.3 * u(rng),
         0.6 + 1.2 * u(rng)};
  }
  // The rig's true bushings are not the configured ones: +-10 %.
  for (int i = 0; i < kNumBushings; ++i) {
    c.sets.push_back({"c_" + std::string(kBushingChassisNames[i]),
                      model.bushings[i].stiffness * (0.9 + 0.2 * u(rng))});
  }
  const double m = c.magnitude;
  char text[200];
  if (c.truth == "bushing_damping") {
    std::snprintf(text, sizeof(text), "bushing_damping:d=%.6g",
                  LogUniform(5e4, 3e6, m));
  } else if (c.truth == "hysteresis") {
    std::snprintf(text, sizeof(text), "hysteresis:force=%.6g,sigma=%.6g",
                  LogUniform(20, 1000, m), LogUniform(1e7, 1e8, u(rng)));
  } else if (c.truth == "progressive_stiffness") {
    std::snprintf(text, sizeof(text), "progressive_stiffness:c3=%.6g",
                  LogUniform(1e11, 1e13, m));
  } else if (c.truth == "actuator_lag") {
    std::snprintf(text, sizeof(text), "actuator_lag:tau=%.6g,dead_time=%.6g",
                  LogUniform(1e-3, 0.05, m), 0.01 * m * u(rng));
  } else if (c.truth == "rig_compliance") {
    std::snprintf(text, sizeof(text), "rig_compliance:k=%.6g",
                  LogUniform(1e8, 2e6, m));
  } else if (c.truth == "sensor_offset") {
    const double f = LogUniform(0.2, 10, m);
    std::snprintf(text, sizeof(text),
                  "sensor_offset:x=%.6g,y=%.6g,z=%.6g,toe=%.6g,camber=%.6g,"
                  "caster=%.6g,scale=%.6g",
                  f * 1e-4 * (2 * u(rng) - 1), f * 1e-4 * (2 * u(rng) - 1),
                  f * 1e-4 * (2 * u(rng) - 1), f * 2e-4 * (2 * u(rng) - 1),
                  f * 2e-4 * (2 * u(rng) - 1), f * 2e-4 * (2 * u(rng) - 1),
                  1 + 0.01 * f * (2 * u(rng) - 1));
  } else if (c.truth == "model_parameter" && rng() % 3 != 0) {
    // A chassis or carrier point off by 1 .. 10 mm along one axis.
    static const char* kPoints[] = {"O1", "O2", "V1", "V2", "P",
                                    "N1", "N2", "U1", "U2", "Q"};
    c.parameter = std::string(kPoints[rng() % 10]) + "." + "xyz"[rng() % 3];
    const double error = (rng() % 2 ? 1 : -1) * LogUniform(1e-3, 1e-2, m);
    c.parameter_value = *FindParameter(model, c.parameter) + error;
  } else if (c.truth == "model_parameter") {
    // The spring rate off by 2 .. 30 %.
    c.parameter = "k_spring";
    const double error = (rng() % 2 ? 1 : -1) * LogUniform(0.02, 0.3, m);
    c.parameter_value = model.spring.stiffness * (1 + error);
  }
  if (!c.parameter.empty()) c.sets.push_back({c.parameter, c.parameter_value});
  if (c.truth != "none" && c.truth != "model_parameter") {
    EXPECT_TRUE(ParseEffect(text, &c.effects).ok()) << text;
    c.cli_truth = std::string("--effect ") + text;
  }
  for (const auto& [name, value] : c.sets) {
    std::snprintf(text, sizeof(text), " --set %s=%.9g", name.c_str(), value);
    c.cli_truth += text;
  }
  return c;
}

// The rig is continuous: the logs come from a plant stepped ten times finer
// than the model (as the emulator's rig.step).
constexpr double kPlantStep = 1e-4;

// The effect's size in the residual: RMS of the nominal fit's weighted
// residual on the noise-free training logs.
double EffectSize(const KcrigConfig& config, const BlindCase& c) {
  SuspensionParameters<double> plant = config.model;
  for (const auto& [name, value] : c.sets) {
    for (const NamedParameter<double>& p : ListParameters(&plant)) {
      if (p.name == name) *p.value = value;
    }
  }
  std::vector<Experiment> experiments(2);
  for (int i = 0; i < 2; ++i) {
    SimulatedRunOptions options;
    options.effects = c.effects;
    options.step = kPlantStep;
    RunLog log;
    EXPECT_TRUE(SimulateRun(plant, c.designs[i].Ramp(config.experiment.fmax),
                            config.experiment, options, &log)
                    .ok());
    EXPECT_TRUE(
        MakeExperiment("oracle", log, config.experiment.step, &experiments[i])
            .ok());
  }
  return NominalFitSigmaHat(config, experiments);
}

void StripTruth(const std::string& csv) {
  const std::string sidecar = csv.substr(0, csv.size() - 4) + ".json";
  nlohmann::ordered_json doc;
  {
    std::ifstream in(sidecar);
    doc = nlohmann::ordered_json::parse(in);
  }
  ASSERT_TRUE(doc.contains("truth")) << sidecar;
  doc.erase("truth");
  doc.erase("noise");
  std::ofstream(sidecar) << doc.dump(2) << "\n";
}

// The two tiers are two test names for ctest.
#ifdef KCRIG_BLIND_FULL_TIER
#define KCRIG_BLIND_SUITE BlindDiagnosisFullTierTest
#else
#define KCRIG_BLIND_SUITE BlindDiagnosisTest
#endif

class KCRIG_BLIND_SUITE : public TempDirTest {};

TEST_F(KCRIG_BLIND_SUITE, VerdictsAgainstTheTruth) {
  const KcrigConfig config = SourceConfig();
  const int cases = KCRIG_BLIND_CASES;
  std::map<std::string, std::map<std::string, int>> confusion;
  int large = 0, large_correct = 0, clean = 0, clean_none = 0;
  int wrong_parameters = 0, named = 0, named_in_ambiguity = 0;
  int confident_misattribution = 0, named_in_interval = 0;
  int correct = 0, closed_enough = 0;
  std::printf("%4s %-22s %6s %7s  %-36s %-5s %7s %6s\n", "case", "truth",
              "magn", "size", "verdict", "conf", "closed", "s");
  for (int i = 0; i < cases; ++i) {
    const BlindCase c = Draw(i, KCRIG_BLIND_SEED, config.model);
    const std::string dir = Path("case" + std::to_string(i));
    std::filesystem::create_directories(dir);
    const char* names[] = {"a.csv", "b.csv", "holdout.csv"};
    for (int k = 0; k < 3; ++k) {
      const std::string csv = dir + "/" + names[k];
      const CliResult sim = RunKcrig(
          "simulate --noise --plant-step " + std::to_string(kPlantStep) +
          " --seed " + std::to_string(c.seed + k) + " " + c.designs[k].Args() +
          " " + c.cli_truth + " --out " + csv);
      ASSERT_EQ(sim.exit_code, 0) << sim.output;
      StripTruth(csv);
    }
    const CliResult run = RunKcrig("diagnose --log " + dir + "/a.csv --log " +
                                   dir + "/b.csv --holdout " + dir +
                                   "/holdout.csv --out " + dir + "/diag.json");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    // Only now is the truth looked at.
    std::ifstream in(dir + "/diag.json");
    const nlohmann::json diag = nlohmann::json::parse(in);
    const std::string verdict = diag["verdict"];
    const std::string model = diag.value("model", "");
    const std::string confidence = diag["confidence"];
    const nlohmann::json ambiguous =
        diag.value("ambiguous", nlohmann::json::array());
    const double closed =
        diag.contains("quantification")
            ? diag["quantification"]["gap_closed"].get<double>()
            : 0.0;
    const double size = c.truth == "none" ? 0.0 : EffectSize(config, c);
    // Noise-free: the residual is the effect alone.
    const double excess = size;
    const std::string column =
        verdict.find('+') != std::string::npos ? "pair" : verdict;
    confusion[c.truth][column] += 1;
    std::printf("%4d %-22s %6.2f %7.2f  %-36s %-5s %6.0f%% %6.1f\n", i,
                c.truth.c_str(), c.magnitude, excess, verdict.c_str(),
                confidence.c_str(), 100 * closed,
                diag["seconds"].get<double>());
    std::printf("     truth %s; designs", c.cli_truth.c_str());
    for (const Design& d : c.designs) std::printf(" [%s]", d.Args().c_str());
    std::printf("\n");
    std::fflush(stdout);
    const std::string truth_model =
        c.parameter.empty() ? c.truth : "model_parameter@" + c.parameter;
    const bool right =
        verdict == c.truth && (c.parameter.empty() || model == truth_model);
    if (c.truth != "none" && right) {
      ++correct;
      closed_enough += closed >= 0.8;
    }
    if (c.truth == "none") {
      ++clean;
      clean_none += verdict == "none";
    } else if (c.parameter.empty() && excess > 3) {
      ++large;
      large_correct += right;
    } else if (!c.parameter.empty() && excess > 3) {
      ++wrong_parameters;
      named += right;
      named_in_ambiguity += verdict == "unexplained" &&
                            std::find(ambiguous.begin(), ambiguous.end(),
                                      truth_model) != ambiguous.end();
      confident_misattribution += !right && confidence == "high";
      for (const nlohmann::json& p :
           diag.value("quantification", nlohmann::json::object())
               .value("effect_parameters", nlohmann::json::array())) {
        if (!right || p["name"] != "model_parameter." + c.parameter) continue;
        named_in_interval += p["ci95"][0] <= c.parameter_value &&
                             c.parameter_value <= p["ci95"][1];
      }
    }
  }

  std::vector<std::string> columns = {"none"};
  columns.insert(columns.end(), kClasses.begin(), kClasses.begin() + 6);
  columns.push_back("model_parameter");
  columns.push_back("pair");
  columns.push_back("unexplained");
  std::printf("\nconfusion matrix (rows: truth, columns: verdict)\n%22s", "");
  for (const std::string& col : columns) {
    std::printf(" %6.6s", col.c_str());
  }
  std::printf("\n");
  for (const std::string& row : kClasses) {
    std::printf("%22s", row.c_str());
    for (const std::string& col : columns) {
      std::printf(" %6d", confusion[row][col]);
    }
    std::printf("\n");
  }
  std::printf(
      "library effects > 3x noise: %d/%d correct; clean: %d/%d none; "
      "wrong parameters > 3x noise: %d/%d named, %d more one of an "
      "ambiguous pair, %d another model with high confidence, true value "
      "in the 95 %% interval %d/%d; correctly attributed with >= 80 %% of "
      "the gap closed: %d/%d\n",
      large_correct, large, clean_none, clean, named, wrong_parameters,
      named_in_ambiguity, confident_misattribution, named_in_interval, named,
      closed_enough, correct);

  ASSERT_GT(large, 0);
  ASSERT_GT(clean, 0);
  ASSERT_GT(wrong_parameters, 0);
  EXPECT_GE(large_correct, 0.9 * large);
  EXPECT_GE(clean_none, 0.95 * clean);
  EXPECT_GE(named + named_in_ambiguity, 0.8 * wrong_parameters);
  EXPECT_EQ(confident_misattribution, 0);
  if (named >= 10) {
    EXPECT_GE(named_in_interval, 0.9 * named);
  }
  EXPECT_EQ(closed_enough, correct);
}

}  // namespace
}  // namespace kcrig
