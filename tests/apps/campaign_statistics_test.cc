// Statistical acceptance of the campaign's closed loop (issue #17), through
// the real CLI on the embedded rig. A generator draws cases from a seed:
// one of the six library effects at a size of at least 3x the noise in the
// residual, or none; true bushings +-10 % off the configured ones; the
// noise seed. Each case runs a 3-iteration campaign (`--iterations 2`) and,
// for the same seed, today's behaviour: the nominal model throughout
// (`--no-diagnose`). Only after campaign.json is written does the test look
// at the truth.
//
// Acceptance: the right effect adopted in >= 90 % of the cases per effect;
// each final stiffness's 95 % interval contains the plant's value in 90-98 %
// of the cases (per parameter, over all effect cases; only the lower end is
// asserted, see below); without an effect,
// nothing adopted in >= 95 % of the cases and the estimates equal today's.
// The effect's size in the residual is the RMS, in noise units, of the
// nominal fit's residual on the campaign's first two experiments simulated
// without noise (as in the blind diagnosis tier).
//
// The embedded rig keeps its plant's state from run to run, as a rig does.
// The full tier also runs three effects (hysteresis in one bushing and in
// every bushing, the rig's compliance) through Modbus TCP on loopback
// against `kcrig emulate --effect` (its plant at rig.step, in real time,
// the runs back to back), as many cases each.
//
// KCRIG_CAMPAIGN_CASES (per effect) and KCRIG_CAMPAIGN_SEED are compile
// definitions: the CI tier and the full tier are two builds of this file.
// The environment variable KCRIG_CAMPAIGN_EFFECTS (comma-separated names)
// runs only those effects' cases, to work on one; a run that way prints
// "effects: only ..." and, when its checks hold, ends skipped: it is not
// the acceptance. KCRIG_CAMPAIGN_SEED in the environment draws other cases
// (independent ones, to tell a figure from its sampling noise).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "emulator/simulated_run.h"
#include "estimator/experiment.h"
#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "records/run_log.h"
#include "tests/support/child_process.h"
#include "tests/support/cli_runner.h"
#include "tests/support/edited_config.h"
#include "tests/support/effect_size.h"
#include "tests/support/temp_dir_test.h"
#include "tests/support/test_config.h"

namespace kcrig {
namespace {

// "hysteresis@bushing": hysteresis in one bushing, drawn per case.
const std::vector<std::string> kEffects = {
    "bushing_damping",       "hysteresis",   "hysteresis@bushing",
    "progressive_stiffness", "actuator_lag", "rig_compliance",
    "sensor_offset"};

// plant.yaml's true bushings, which the cases scale by +-10 %.
const double kPlantStiffness[kNumBushings] = {3.6e6, 4.4e6, 3.9e6, 4.25e6,
                                              3.75e6};
const char* const kPlantStiffnessText[kNumBushings] = {
    "c_O1: 3.6e6", "c_O2: 4.4e6", "c_V1: 3.9e6", "c_V2: 4.25e6", "c_P: 3.75e6"};

struct CampaignCase {
  std::string effect;  // one of kEffects or "none"
  std::string spec;    // --plant-effect value; empty for none
  std::string model;   // the model that explains it ("hysteresis@bushing:P")
  double stiffness[kNumBushings] = {};
  std::uint64_t seed = 0;
};

double LogUniform(double low, double high, double u) {
  return low * std::pow(high / low, u);
}

// Magnitudes from the upper part of the blind tier's ranges: each is at
// least 3x the noise in the residual of the campaign's experiments.
std::string DrawSpec(const std::string& effect, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(0, 1);
  char text[240];
  if (effect == "bushing_damping") {
    std::snprintf(text, sizeof(text), "bushing_damping:d=%.6g",
                  LogUniform(5e5, 3e6, u(*rng)));
  } else if (effect == "hysteresis" || effect == "hysteresis@bushing") {
    // sigma drawn first, as above. One bushing's loop moves
    // the sensors less than five: its force is drawn larger.
    const double sigma = LogUniform(1e7, 1e8, u(*rng));
    const double force = effect == "hysteresis"
                             ? LogUniform(200, 1000, u(*rng))
                             : LogUniform(400, 2000, u(*rng));
    if (effect == "hysteresis") {
      std::snprintf(text, sizeof(text), "hysteresis:force=%.6g,sigma=%.6g",
                    force, sigma);
    } else {
      const int bushing =
          std::min(kNumBushings - 1, static_cast<int>(u(*rng) * kNumBushings));
      std::snprintf(text, sizeof(text),
                    "hysteresis:force=%.6g,sigma=%.6g,at=bushing:%s", force,
                    sigma, std::string(kBushingChassisNames[bushing]).c_str());
    }
  } else if (effect == "progressive_stiffness") {
    std::snprintf(text, sizeof(text), "progressive_stiffness:c3=%.6g",
                  LogUniform(2e12, 1e13, u(*rng)));
  } else if (effect == "actuator_lag") {
    // In the order g++ evaluated these as the arguments of one call (right
    // to left), which drew the tier's cases: the same cases on any compiler.
    const double dead_time = 0.01 * u(*rng);
    const double tau = LogUniform(0.01, 0.05, u(*rng));
    std::snprintf(text, sizeof(text), "actuator_lag:tau=%.6g,dead_time=%.6g",
                  tau, dead_time);
  } else if (effect == "rig_compliance") {
    std::snprintf(text, sizeof(text), "rig_compliance:k=%.6g",
                  LogUniform(3e6, 7e6, u(*rng)));
  } else if (effect == "sensor_offset") {
    const double f = LogUniform(2, 10, u(*rng));
    // The signs of scale, caster, ..., x: drawn last to first, as above.
    double sign[7];
    for (int k = 6; k >= 0; --k) sign[k] = u(*rng) < 0.5 ? -1.0 : 1.0;
    std::snprintf(text, sizeof(text),
                  "sensor_offset:x=%.6g,y=%.6g,z=%.6g,toe=%.6g,camber=%.6g,"
                  "caster=%.6g,scale=%.6g",
                  f * 1e-4 * sign[0], f * 1e-4 * sign[1], f * 1e-4 * sign[2],
                  f * 2e-4 * sign[3], f * 2e-4 * sign[4], f * 2e-4 * sign[5],
                  1 + 0.01 * f * sign[6]);
  } else {
    return "";
  }
  return text;
}

CampaignCase Draw(const std::string& effect, int index, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 1000003 + index * 101 +
                      std::hash<std::string>()(effect) % 97);
  std::uniform_real_distribution<double> u(0, 1);
  CampaignCase c;
  c.effect = effect;
  c.seed = seed * 1000 + index + 1;
  for (int i = 0; i < kNumBushings; ++i) {
    c.stiffness[i] = kPlantStiffness[i] * (0.9 + 0.2 * u(rng));
  }
  c.spec = DrawSpec(effect, &rng);
  // The model that names the effect and, when placed, its component.
  const size_t at = c.spec.find(",at=");
  c.model = effect == "hysteresis@bushing"
                ? "hysteresis@" + c.spec.substr(at + 4)
                : effect;
  return c;
}

// config/ with the case's true bushings in plant.yaml, and the loop's
// error detector (rig.yaml: 2 mm, 0.5 deg between the rig and the nominal
// model's live prediction) ten times wider: the tier's effects are drawn
// large, and the rig's safety would trip on some of them, as it should on
// a real rig (sil_rig_test and hil_cli_test test the detector itself).
std::string CaseConfig(const std::string& dir, const CampaignCase& c) {
  EditConfig(dir, "rig.yaml", "error_position_max: 0.002",
             "error_position_max: 0.02");
  EditConfig(dir, "rig.yaml", "error_angle_max_deg: 0.5",
             "error_angle_max_deg: 5.0");
  for (int i = 0; i < kNumBushings; ++i) {
    char to[64];
    const std::string name(kBushingChassisNames[i]);
    std::snprintf(to, sizeof(to), "c_%s: %.9g", name.c_str(), c.stiffness[i]);
    EditConfig(dir, "plant.yaml", kPlantStiffnessText[i], to);
  }
  return dir;
}

// What a campaign ended with, read from campaign.json.
struct Outcome {
  std::string model;  // the final iteration's model
  bool stopped = false;
  double value[kNumBushings] = {};
  double low[kNumBushings] = {}, high[kNumBushings] = {};
};

Outcome ReadOutcome(const std::string& dir) {
  Outcome o;
  std::ifstream in(dir + "/campaign.json");
  const nlohmann::json doc = nlohmann::json::parse(in);
  const nlohmann::json& last = doc["iterations"].back();
  o.model = last["model"];
  o.stopped = last.contains("diagnosis") && last["diagnosis"].is_object() &&
              last["diagnosis"]["action"] == "stopped";
  for (int i = 0; i < kNumBushings; ++i) {
    const nlohmann::json& p = last["parameters"][i];
    // No interval (a parameter the logs do not determine) covers nothing.
    const bool interval = p.value("identifiable", true) &&
                          p["ci95"].is_array() && p["ci95"][0].is_number() &&
                          p["ci95"][1].is_number();
    o.value[i] = p["value"].is_number() ? p["value"].get<double>() : NAN;
    o.low[i] = interval ? p["ci95"][0].get<double>() : NAN;
    o.high[i] = interval ? p["ci95"][1].get<double>() : NAN;
  }
  return o;
}

// The effect's size in the residual (see the file comment).
double EffectSize(const KcrigConfig& config, const CampaignCase& c,
                  const std::string& campaign_dir) {
  SuspensionParameters<double> plant = config.model;
  for (int i = 0; i < kNumBushings; ++i) {
    plant.bushings[i].stiffness = c.stiffness[i];
  }
  PlantEffects effects;
  EXPECT_TRUE(ParseEffect(c.spec, &effects).ok()) << c.spec;
  std::vector<Experiment> experiments;
  for (const char* iteration : {"iteration_0", "iteration_1"}) {
    RunLog logged;
    const Status read =
        ReadRunLog(campaign_dir + "/" + iteration + "/run.csv", &logged);
    EXPECT_TRUE(read.ok()) << read.message();
    if (!read.ok()) return 0;
    SimulatedRunOptions options;
    options.effects = effects;
    options.step = 1e-4;  // plant.yaml's rig.step, as the embedded rig
    RunLog log;
    EXPECT_TRUE(SimulateRun(plant, logged.metadata.excitation,
                            config.experiment, options, &log)
                    .ok());
    experiments.emplace_back();
    EXPECT_TRUE(MakeExperiment(iteration, log, config.experiment.step,
                               &experiments.back())
                    .ok());
  }
  return NominalFitSigmaHat(config, experiments);
}

std::string CampaignCommand(const std::string& config, const CampaignCase& c,
                            const std::string& out, bool diagnose) {
  std::string command = "campaign --config " + config +
                        " --iterations 2 --quiet --no-report --seed " +
                        std::to_string(c.seed) + " --out " + out;
  if (!c.spec.empty()) command += " --plant-effect " + c.spec;
  if (!diagnose) command += " --no-diagnose";
  return command;
}

// The largest distance of an estimate from its truth, in its interval's
// half-widths (above 1: missed): a miss by a hair or by a mile.
double WorstMiss(const Outcome& o, const CampaignCase& c) {
  double worst = 0;
  for (int i = 0; i < kNumBushings; ++i) {
    const double half = 0.5 * (o.high[i] - o.low[i]);
    worst = std::max(worst, std::abs(o.value[i] - c.stiffness[i]) / half);
  }
  return worst;
}

int Covered(const Outcome& o, const CampaignCase& c, bool* per_parameter) {
  int covered = 0;
  for (int i = 0; i < kNumBushings; ++i) {
    per_parameter[i] =
        o.low[i] <= c.stiffness[i] && c.stiffness[i] <= o.high[i];
    covered += per_parameter[i];
  }
  return covered;
}

#ifdef KCRIG_CAMPAIGN_FULL_TIER
#define KCRIG_CAMPAIGN_SUITE CampaignStatisticsFullTierTest
#else
#define KCRIG_CAMPAIGN_SUITE CampaignStatisticsTest
#endif

// The seed of the cases: the build's, or KCRIG_CAMPAIGN_SEED's.
int CampaignSeed() {
  const char* seed = std::getenv("KCRIG_CAMPAIGN_SEED");
  return seed != nullptr ? std::atoi(seed) : KCRIG_CAMPAIGN_SEED;
}

class KCRIG_CAMPAIGN_SUITE : public TempDirTest {
 protected:
  // Runs the case's campaign with the checks acting and with the nominal
  // model throughout; returns false when either failed to run.
  bool RunCase(const CampaignCase& c, const std::string& name, Outcome* acting,
               Outcome* nominal) {
    const std::string config = CaseConfig(Path(name + "_config"), c);
    const CliResult run =
        RunKcrig(CampaignCommand(config, c, Path(name), true));
    EXPECT_TRUE(run.exit_code == 0 || run.exit_code == 5) << run.output;
    const CliResult today =
        RunKcrig(CampaignCommand(config, c, Path(name + "_nominal"), false));
    EXPECT_EQ(today.exit_code, 0) << today.output;
    if ((run.exit_code != 0 && run.exit_code != 5) || today.exit_code != 0) {
      return false;
    }
    *acting = ReadOutcome(Path(name));
    *nominal = ReadOutcome(Path(name + "_nominal"));
    return true;
  }
};

// kEffects, or those named in KCRIG_CAMPAIGN_EFFECTS.
std::vector<std::string> EffectsToRun() {
  const char* only = std::getenv("KCRIG_CAMPAIGN_EFFECTS");
  if (only == nullptr) return kEffects;
  std::printf("effects: only %s\n", only);
  std::vector<std::string> chosen;
  for (const std::string& effect : kEffects) {
    if (("," + std::string(only) + ",").find("," + effect + ",") !=
        std::string::npos) {
      chosen.push_back(effect);
    }
  }
  return chosen;
}

TEST_F(KCRIG_CAMPAIGN_SUITE, LibraryEffectsAreAdoptedAndTheIntervalsCover) {
  const KcrigConfig config = SourceConfig();
  const int cases = KCRIG_CAMPAIGN_CASES;
  int counted = 0, adopted_total = 0;
  int covered[kNumBushings] = {}, nominal_covered[kNumBushings] = {};
  // Of the campaigns that adopted the right effect: how far the intervals
  // they present can be trusted (a stopped campaign presents none).
  int adopted_intervals = 0, adopted_covered = 0;
  std::printf("%-22s %4s %6s  %-22s %-8s %-6s %-14s %s\n", "effect", "case",
              "size", "final model", "covered", "worst", "today covered",
              "plant effect");
  for (const std::string& effect : EffectsToRun()) {
    int adopted = 0, large = 0, stopped = 0;
    for (int k = 0; k < cases; ++k) {
      const CampaignCase c = Draw(effect, k, CampaignSeed());
      const std::string name = effect + std::to_string(k);
      Outcome acting, nominal;
      if (!RunCase(c, name, &acting, &nominal)) continue;
      // Only now is the truth looked at.
      const double size = EffectSize(config, c, Path(name));
      bool hit[kNumBushings], nominal_hit[kNumBushings];
      const int n = Covered(acting, c, hit);
      const int n_nominal = Covered(nominal, c, nominal_hit);
      const std::string final_model =
          acting.stopped ? "stopped (exit 5)" : acting.model;
      std::printf("%-22s %4d %6.1f  %-22s %d/5      %6.2f %d/5            %s\n",
                  effect.c_str(), k, size, final_model.c_str(), n,
                  WorstMiss(acting, c), n_nominal, c.spec.c_str());
      std::fflush(stdout);
      if (size < 3) continue;  // below the acceptance's size: shown only
      ++large;
      // Adopted and kept: a campaign that adopted the effect and stopped
      // later (exit 5) did not end with it.
      const bool kept = acting.model == c.model && !acting.stopped;
      adopted += kept;
      stopped += acting.stopped;
      if (kept) {
        adopted_intervals += kNumBushings;
        adopted_covered += n;
      }
      for (int i = 0; i < kNumBushings; ++i) {
        covered[i] += hit[i];
        nominal_covered[i] += nominal_hit[i];
      }
    }
    std::printf(
        "%s: right effect adopted in %d of %d cases >= 3x noise; %d stopped "
        "(exit 5: no effect explains the logs)\n",
        effect.c_str(), adopted, large, stopped);
    EXPECT_GE(adopted, 0.9 * large) << effect;
    EXPECT_GT(large, 0) << effect;
    counted += large;
    adopted_total += adopted;
  }
  std::printf(
      "\nall effects: right effect adopted in %d of %d cases\n"
      "coverage of the 95 %% intervals (final iteration), per stiffness:\n"
      "  %-6s %-22s %-22s\n",
      adopted_total, counted, "", "checks acting", "today (nominal)");
  ASSERT_GT(counted, 0);
  std::printf(
      "  of the campaigns that adopted the right effect: %d of %d intervals "
      "cover the plant's stiffness\n",
      adopted_covered, adopted_intervals);
  int misses = 0;
  for (int i = 0; i < kNumBushings; ++i) {
    std::printf("  c_%-4s %3d/%-3d = %5.1f %%        %3d/%-3d = %5.1f %%\n",
                std::string(kBushingChassisNames[i]).c_str(), covered[i],
                counted, 100.0 * covered[i] / counted, nominal_covered[i],
                counted, 100.0 * nominal_covered[i] / counted);
    misses += counted - covered[i];
#ifdef KCRIG_CAMPAIGN_FULL_TIER
    // The goal is 90-98 %; its upper end is not asserted: with 95 %
    // intervals, 120 cases cover all with probability 6 % per stiffness.
    EXPECT_GE(covered[i], 0.90 * counted) << kBushingChassisNames[i];
#endif
  }
#ifndef KCRIG_CAMPAIGN_FULL_TIER
  // Few cases: all intervals together, against the binomial tail. With
  // 95 % intervals, more misses than this has probability < 0.3 %.
  const int intervals = kNumBushings * counted;
  const double mean = 0.05 * intervals;
  EXPECT_LE(misses, mean + 3 * std::sqrt(mean * 0.95) + 1)
      << misses << " of " << intervals << " intervals miss the truth";
#endif
  if (std::getenv("KCRIG_CAMPAIGN_EFFECTS") != nullptr) {
    GTEST_SKIP() << "KCRIG_CAMPAIGN_EFFECTS ran only some effects: checked "
                    "as far as they go, not passed as the acceptance";
  }
}

TEST_F(KCRIG_CAMPAIGN_SUITE,
       WithoutAnEffectNothingIsAdoptedAndTheEstimatesAreTodays) {
  const int cases = KCRIG_CAMPAIGN_CASES;
  int adopted_nothing = 0, same = 0, covered = 0;
  for (int k = 0; k < cases; ++k) {
    const CampaignCase c = Draw("none", k, CampaignSeed());
    const std::string name = "none" + std::to_string(k);
    Outcome acting, nominal;
    if (!RunCase(c, name, &acting, &nominal)) continue;
    bool hit[kNumBushings];
    covered += Covered(acting, c, hit);
    adopted_nothing += acting.model == "nominal" && !acting.stopped;
    bool equal = true;
    for (int i = 0; i < kNumBushings; ++i) {
      equal = equal && acting.value[i] == nominal.value[i] &&
              acting.low[i] == nominal.low[i] &&
              acting.high[i] == nominal.high[i];
    }
    same += equal;
    const bool nothing_adopted = acting.model == "nominal" && !acting.stopped;
    EXPECT_TRUE(equal || !nothing_adopted)
        << "case " << k << ": nothing adopted, yet the estimates differ";
    std::printf("none %2d: final model %s%s, estimates %s today's\n", k,
                acting.model.c_str(), acting.stopped ? " (stopped)" : "",
                equal ? "equal to" : "differ from");
  }
  std::printf(
      "no effect: nothing adopted in %d of %d cases, estimates equal to "
      "today's in %d; %d of %d intervals cover the truth\n",
      adopted_nothing, cases, same, covered, kNumBushings * cases);
  EXPECT_GE(adopted_nothing, 0.95 * cases);
}

#ifdef KCRIG_CAMPAIGN_FULL_TIER
// The campaign of a case through Modbus TCP against `kcrig emulate` on a free
// loopback port with the case's plant (its bushings in plant.yaml, its
// effect, its noise seed): the emulator keeps its plant's state from run to
// run, as a rig does. Returns false when it did not run to an outcome; a
// run that the controller's watchdog stopped (the shared machine starved the
// emulator of measurements: the safety working, not an outcome of the
// estimation) sets `tripped`.
bool RunModbusCase(const CampaignCase& c, const std::string& config,
                   const std::string& out, Outcome* outcome, bool* tripped) {
  // One output file per emulator: a second would otherwise be read for its
  // port before it replaced the first's (a closed port).
  ChildProcess emulator(
      {KCRIG_BINARY, "emulate", "--config", config, "--modbus-tcp",
       "127.0.0.1:0", "--seed", std::to_string(c.seed), "--effect", c.spec},
      out + "_emulate.out");
  const std::string port =
      emulator.WaitForOutput("serving modbus-tcp://127\\.0\\.0\\.1:([0-9]+)");
  EXPECT_FALSE(port.empty()) << emulator.Output();
  if (port.empty()) return false;
  const CliResult run = RunKcrig(
      "campaign --config " + config + " --rig modbus-tcp://127.0.0.1:" + port +
      " --iterations 2 --quiet --no-report --out " + out);
  const bool ran = run.exit_code == 0 || run.exit_code == 5;
  *tripped = !ran && run.output.find(" tripped: watchdog") != std::string::npos;
  EXPECT_TRUE(ran || *tripped) << run.output;
  if (ran) *outcome = ReadOutcome(out);
  return ran;
}

// Hysteresis in one bushing, in every bushing, and the rig's compliance,
// each as many cases as the tier has, through Modbus with the runs back to
// back. Every case counts (their sizes are not computed: the emulator's
// plant runs at rig.step in real time, the effects are drawn large).
TEST_F(KCRIG_CAMPAIGN_SUITE, EffectsThroughModbusAgainstTheEmulator) {
  const int cases = KCRIG_CAMPAIGN_CASES;
  int counted = 0, retried = 0;
  int covered[kNumBushings] = {};
  for (const std::string& effect : std::vector<std::string>{
           "hysteresis@bushing", "hysteresis", "rig_compliance"}) {
    int adopted = 0, stopped = 0, ran_cases = 0;
    for (int k = 0; k < cases; ++k) {
      const CampaignCase c = Draw(effect, 100 + k, CampaignSeed());
      const std::string name = "modbus_" + effect + std::to_string(k);
      const std::string config = CaseConfig(Path(name + "_config"), c);
      Outcome outcome;
      bool tripped = false;
      bool ran = RunModbusCase(c, config, Path(name), &outcome, &tripped);
      if (!ran && tripped) {
        ++retried;
        std::printf("modbus %s %2d: a run tripped; the case runs once more\n",
                    effect.c_str(), k);
        ran =
            RunModbusCase(c, config, Path(name + "_retry"), &outcome, &tripped);
      }
      if (!ran) continue;
      bool hit[kNumBushings];
      const int n = Covered(outcome, c, hit);
      std::printf("modbus %-20s %2d: final model %s, covered %d/5 (%s)\n",
                  effect.c_str(), k,
                  outcome.stopped ? "stopped (exit 5)" : outcome.model.c_str(),
                  n, c.spec.c_str());
      std::fflush(stdout);
      ++ran_cases;
      adopted += outcome.model == c.model && !outcome.stopped;
      stopped += outcome.stopped;
      for (int i = 0; i < kNumBushings; ++i) covered[i] += hit[i];
    }
    std::printf(
        "through Modbus: %s adopted and kept in %d of %d cases, %d stopped\n",
        effect.c_str(), adopted, ran_cases, stopped);
    EXPECT_GT(ran_cases, 0) << effect;
    EXPECT_GE(adopted, 0.9 * ran_cases) << effect;
    counted += ran_cases;
  }
  std::printf("(%d cases run again after a watchdog trip)\n", retried);
  ASSERT_GT(counted, 0);
  for (int i = 0; i < kNumBushings; ++i) {
    std::printf("  c_%-4s covered %d/%d = %5.1f %%\n",
                std::string(kBushingChassisNames[i]).c_str(), covered[i],
                counted, 100.0 * covered[i] / counted);
    EXPECT_GE(covered[i], 0.90 * counted) << kBushingChassisNames[i];
  }
}
#endif

}  // namespace
}  // namespace kcrig
