// `kcrig report` through the real CLI: the data the page is built from (read
// back out of the written HTML) and the errors on bad folders. That every
// figure renders in a browser is report_browser_test's job.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "gtest/gtest.h"
#include "nlohmann/json.hpp"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The JSON the page draws from, as inlined in the HTML.
Json PageData(const std::string& html) {
  const std::string open =
      "<script type=\"application/json\" id=\"kcrig-data\">";
  const size_t begin = html.find(open);
  EXPECT_NE(begin, std::string::npos);
  const size_t end = html.find("</script>", begin);
  std::string json =
      html.substr(begin + open.size(), end - begin - open.size());
  return Json::parse(json);
}

// One small campaign per test process that needs it (ctest runs each test
// in its own process, two at a time: the folder is the process's), built
// on first use: under the sanitizers a campaign takes a minute, and one
// that judges isolability (47 candidates' sensitivities per experiment)
// three; only the test of the report's figures needs that one.
class ReportCliTest : public TempDirTest {
 protected:
  enum Judge { kIsolability, kNothingMore, kJudges };
  // One folder per kind, so any order of tests in one process gets the
  // campaign it asked for.
  static const std::string& Campaign(Judge judge) {
    std::string*& campaign = campaigns_[judge];
    if (campaign == nullptr) {
      campaign = new std::string(
          (fs::temp_directory_path() /
           ("kcrig_report_cli_campaign_" + std::to_string(getpid()) + "_" +
            std::to_string(judge)))
              .string());
      fs::remove_all(*campaign);
      const CliResult r =
          RunKcrig(std::string("campaign --iterations 1 --budget 12 --quiet ") +
                   (judge == kIsolability ? "--isolability " : "") +
                   "--no-report --out " + *campaign);
      EXPECT_EQ(r.exit_code, 0) << r.output;
    }
    return *campaign;
  }
  static void TearDownTestSuite() {
    for (std::string*& campaign : campaigns_) {
      if (campaign == nullptr) continue;
      fs::remove_all(*campaign);
      delete campaign;
      campaign = nullptr;
    }
  }
  static std::string* campaigns_[kJudges];
};
std::string* ReportCliTest::campaigns_[kJudges] = {};

TEST_F(ReportCliTest, CampaignReportCarriesEveryFiguresDataInEngineersUnits) {
  const std::string& campaign = Campaign(kIsolability);
  ASSERT_FALSE(fs::exists(campaign + "/report.html"));
  const std::string html = Path("report.html");
  const CliResult r = RunKcrig("report --from " + campaign +
                               " --grid 4x3 --quiet --out " + html);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // 2 experiments, sensitivities, estimates, D and A surfaces, kriging,
  // the isolability matrix, the K&C loops of the 2 runs.
  EXPECT_NE(r.output.find("10 figures (2 experiments, campaign)"),
            std::string::npos)
      << r.output;
  const std::string text = ReadText(html);
  // Self-contained: plotly inlined, nothing fetched.
  EXPECT_NE(text.find("plotly.js v"), std::string::npos);
  EXPECT_EQ(text.find("<script src="), std::string::npos);
  const Json data = PageData(text);
  EXPECT_EQ(data["expected_figures"], 10);
  // The last iteration's isolability, as the campaign wrote it.
  EXPECT_EQ(data["isolability"]["iteration"], 1);
  EXPECT_EQ(data["isolability"]["candidates"].size(), 47u);
  EXPECT_EQ(data["isolability"]["left"].size(), 47u);
  // campaign.json counts what each iteration's logs tell apart, and the
  // ties the next experiment leaves (none after the last).
  const Json summary = Json::parse(std::ifstream(campaign + "/campaign.json"));
  const Json& first = summary["iterations"][0]["isolability"];
  EXPECT_EQ(first["num_candidates"], 47);
  EXPECT_GT(first["pairs"].get<int>(), 1000);
  EXPECT_TRUE(first["ties_with_next"].is_number());
  EXPECT_TRUE(
      summary["iterations"][1]["isolability"]["ties_with_next"].is_null());
  // The K&C sheet of both runs against the final model, with their loops:
  // the rising branch is the 4 s ramp, decimated to at most 1001 points.
  ASSERT_EQ(data["kc"]["sheet"]["runs"].size(), 2u);
  ASSERT_EQ(data["kc"]["loops"].size(), 2u);
  for (const Json& loops : data["kc"]["loops"]) {
    ASSERT_EQ(loops["branches"].size(), 1u);
    const Json& rising = loops["branches"][0];
    EXPECT_EQ(rising["name"], "rising");
    EXPECT_LE(rising["force"].size(), 1001u);
    EXPECT_GT(rising["force"].size(), 500u);
    ASSERT_EQ(rising["rig"].size(), 6u);
    EXPECT_EQ(rising["rig"][3].size(), rising["force"].size());
    // From -Fmax to +Fmax, in kN.
    EXPECT_NEAR(rising["force"][0].get<double>(), -4.0, 0.05);
    EXPECT_NEAR(rising["force"].back().get<double>(), 4.0, 0.05);
  }
  EXPECT_EQ(data["kc"]["sheet"]["compliance"]["wheel_centre"]["matrix"].size(),
            6u);

  ASSERT_EQ(data["experiments"].size(), 2u);
  for (const Json& e : data["experiments"]) {
    ASSERT_EQ(e["channels"].size(), 6u);
    EXPECT_LE(e["t"].size(), 1001u);
    for (const Json& c : e["channels"]) {
      const std::string name = c["name"];
      EXPECT_EQ(c["unit"],
                name == "x" || name == "y" || name == "z" ? "mm" : "deg");
      ASSERT_EQ(c["measured"].size(), e["t"].size());
      // The model at the final estimate leaves the sensor noise: its RMS
      // is the sigma (0.02 mm, 0.01 deg) within sampling error.
      const double ratio = c["rms"].get<double>() / c["sigma"].get<double>();
      EXPECT_GT(ratio, 0.9) << e["name"] << " " << name;
      EXPECT_LT(ratio, 1.1) << e["name"] << " " << name;
    }
  }
  const Json& estimates = data["estimates"];
  EXPECT_EQ(estimates["units"], Json({"N/mm", "N/mm", "N/mm", "N/mm", "N/mm"}));
  ASSERT_EQ(estimates["parameters"].size(), 5u);
  ASSERT_EQ(estimates["value"].size(), 2u);
  for (int i = 0; i < 2; ++i) {
    for (int p = 0; p < 5; ++p) {
      const double v = estimates["value"][i][p];
      EXPECT_GT(v, 3000);  // plant.yaml: 3600 .. 4400 N/mm
      EXPECT_LT(v, 5000);
      EXPECT_LT(estimates["ci95_low"][i][p].get<double>(), v);
      EXPECT_GT(estimates["ci95_high"][i][p].get<double>(), v);
    }
  }
  // The summary the page opens with: the final estimate as the last
  // iteration's row above, the checks and action of each iteration as
  // campaign.json wrote them.
  const Json& outcome = data["campaign_summary"];
  EXPECT_EQ(outcome["model"], summary["iterations"][1]["model"]);
  // The final estimate passes the fit, prediction and consistency checks
  // (its residual is the noise, above).
  EXPECT_EQ(outcome["check"], "ok") << outcome;
  ASSERT_EQ(outcome["estimates"].size(), 5u);
  for (int p = 0; p < 5; ++p) {
    const Json& e = outcome["estimates"][p];
    EXPECT_EQ(e["name"], estimates["parameters"][p]);
    EXPECT_EQ(e["unit"], "N/mm");
    EXPECT_EQ(e["value"], estimates["value"][1][p]);
    EXPECT_EQ(e["ci95_low"], estimates["ci95_low"][1][p]);
    EXPECT_EQ(e["ci95_high"], estimates["ci95_high"][1][p]);
  }
  ASSERT_EQ(outcome["iterations"].size(), 2u);
  for (int i = 0; i < 2; ++i) {
    const Json& row = outcome["iterations"][i];
    EXPECT_EQ(row["index"], i);
    EXPECT_EQ(row["logs"], i + 1);
    EXPECT_EQ(row["checks"], summary["iterations"][i]["check"]) << row;
  }
  // The designed experiment lowers log10 diag((J^T J)^-1) of every
  // parameter (more information).
  for (int p = 0; p < 5; ++p) {
    EXPECT_LT(estimates["log10_diag_inv_jtj"][1][p].get<double>(),
              estimates["log10_diag_inv_jtj"][0][p].get<double>());
  }
  // Where the final fit's model started each log: at rest under the first
  // force (the nominal model has no memory), the tare's mean in mm and deg.
  const Json& states = data["initial_states"];
  EXPECT_EQ(states["iteration"], 1);
  ASSERT_EQ(states["logs"].size(), 2u) << states;
  for (const Json& log : states["logs"]) {
    EXPECT_EQ(log["log"].get<std::string>().rfind("iteration_", 0), 0u) << log;
    EXPECT_EQ(log["first_row_pose"], false);
    EXPECT_TRUE(log["dahl_force_N"].is_null());
    ASSERT_EQ(log["tare_mean"].size(), 6u) << log;
    // At zero force the wheel centre rests within a tenth of a millimetre.
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(std::abs(log["tare_mean"][k].get<double>()), 0.1) << log;
    }
  }
  ASSERT_EQ(data["surfaces"].size(), 2u);
  for (const Json& s : data["surfaces"]) {
    ASSERT_EQ(s["phi_deg"].size(), 4u);
    ASSERT_EQ(s["z_a"].size(), 3u);
    EXPECT_DOUBLE_EQ(s["phi_deg"][0].get<double>(), 0.0);
    EXPECT_DOUBLE_EQ(s["phi_deg"][3].get<double>(), 90.0);
    ASSERT_EQ(s["values"].size(), 3u);
    for (const Json& row : s["values"]) {
      ASSERT_EQ(row.size(), 4u);
      for (const Json& v : row) EXPECT_TRUE(std::isfinite(v.get<double>()));
    }
  }
  // The campaign designed with D: its optimizer's points are on D's surface.
  EXPECT_EQ(data["surfaces"][0]["criterion"], "D");
  ASSERT_EQ(data["surfaces"][0]["runs"].size(), 1u);
  EXPECT_FALSE(data["surfaces"][0]["runs"][0]["evaluated"].empty());
  EXPECT_TRUE(data["surfaces"][1]["runs"].empty());
  ASSERT_TRUE(data["kriging"].is_object());
  EXPECT_FALSE(data["kriging"]["panels"].empty());
  EXPECT_TRUE(data["diagnoses"].empty());
  EXPECT_TRUE(data["timings"].empty());
}

TEST_F(ReportCliTest, DiagnosisAndTimingFilesInTheFolderArePickedUp) {
  const std::string dir = Path("diag");
  fs::create_directories(dir);
  const std::string effect = " --effect rig_compliance:k=1e7";
  for (const auto& [name, args] :
       {std::pair<std::string, std::string>{"a", "--phi 85 --z -0.45"},
        {"b", "--phi 10 --z -0.1"},
        {"h", "--phi 45 --z -0.3"}}) {
    const CliResult sim =
        RunKcrig("simulate --noise --seed 3 " + args + effect +
                 " --duration 1.5 --out " + dir + "/" + name + ".csv");
    ASSERT_EQ(sim.exit_code, 0) << sim.output;
  }
  const CliResult diag = RunKcrig(
      "diagnose --quiet --candidates rig_compliance,sensor_offset "
      "--log " +
      dir + "/a.csv --log " + dir + "/b.csv --holdout " + dir +
      "/h.csv --out " + dir + "/diag.json");
  ASSERT_EQ(diag.exit_code, 0) << diag.output;
  // A timing.json as timing-check writes it (the real one needs a 1 kHz
  // loop: report_browser_test runs it).
  std::ofstream(dir + "/timing.json") << R"({"format": "kcrig timing 1",
    "period_us": 1000.0, "cycles": 3, "overruns": 1, "skipped_cycles": 0,
    "phases": {"wakeup": {"p99_us": 30, "max_us": 40,
                          "histogram_us": [[20.0, 2], [40.0, 1]]},
               "compute": {"p99_us": 5, "max_us": 6,
                           "histogram_us": [[5.0, 3]]}},
    "budget": {"compute_p999_fraction": 0.2, "wakeup_p99_us": 500.0,
               "cycle_p999_fraction": 0.8, "within": true,
               "violations": []}})";
  const CliResult r =
      RunKcrig("report --from " + dir + " --quiet --out " + Path("r.html"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("4 figures (0 experiments, diagnosis, timing)"),
            std::string::npos)
      << r.output;
  const Json data = PageData(ReadText(Path("r.html")));
  const Json written = Json::parse(std::ifstream(dir + "/diag.json"));
  ASSERT_EQ(data["diagnoses"].size(), 1u);
  const Json& d = data["diagnoses"][0];
  EXPECT_EQ(d["verdict"], written["verdict"]);
  EXPECT_EQ(d["verdict"], "rig_compliance");
  EXPECT_EQ(d["channels"].size(), 6u);
  EXPECT_FALSE(d["regimes"].empty());
  EXPECT_EQ(d["energy"].size(), d["regimes"].size());
  // The overlay is on the held-out log; the attributed model fits it to
  // the noise, the nominal one does not.
  EXPECT_EQ(d["overlay_on"], "held-out log");
  const Json& overlay = d["overlay"];
  EXPECT_EQ(overlay["log"], "h.csv");
  for (const Json& c : overlay["channels"]) {
    EXPECT_LT(c["attributed_rms"].get<double>(), 1.2 * c["sigma"].get<double>())
        << c["name"];
  }
  EXPECT_GT(overlay["channels"][0]["rms"].get<double>(),
            2 * overlay["channels"][0]["sigma"].get<double>());
  ASSERT_EQ(data["timings"].size(), 1u);
  EXPECT_EQ(data["timings"][0]["budget_us"]["wakeup"], 500.0);
  EXPECT_EQ(data["timings"][0]["budget_us"]["compute"], 200.0);
  EXPECT_EQ(data["timings"][0]["overruns"], 1);
}

TEST_F(ReportCliTest, ValidationInTheFolderIsDrawnInTheConfusionMatrixsOrder) {
  const std::string dir = Path("validation");
  fs::create_directories(dir);
  const CliResult v = RunKcrig(
      "validate --quiet --cases 2 --effects bushing_damping,none "
      "--out " +
      dir + "/validate.json");
  ASSERT_EQ(v.exit_code, 0) << v.output;
  const CliResult r =
      RunKcrig("report --from " + dir + " --quiet --out " + Path("r.html"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("4 figures (0 experiments, validation)"),
            std::string::npos)
      << r.output;
  const Json written = Json::parse(std::ifstream(dir + "/validate.json"));
  const Json data = PageData(ReadText(Path("r.html")));
  ASSERT_EQ(data["validations"].size(), 1u);
  const Json& page = data["validations"][0];
  EXPECT_EQ(page["source"], "validate.json");
  // The truths in the generator's order, every verdict column, and each
  // count where validate.json put it.
  const Json& confusion = page["confusion"];
  EXPECT_EQ(confusion["rows"], Json({"bushing_damping", "none"}));
  EXPECT_EQ(confusion["columns"].front(), "none");
  EXPECT_EQ(confusion["columns"].back(), "unexplained");
  int total = 0;
  for (size_t i = 0; i < confusion["rows"].size(); ++i) {
    const std::string truth = confusion["rows"][i];
    for (size_t j = 0; j < confusion["columns"].size(); ++j) {
      const int n = confusion["counts"][i][j];
      total += n;
      EXPECT_EQ(n, written["confusion"][truth].value(
                       confusion["columns"][j].get<std::string>(), 0));
    }
  }
  EXPECT_EQ(total, 2);
  // Where the damping acts (one bushing or all five) against where the
  // diagnosis placed it: one case.
  const Json& places = page["places"];
  ASSERT_EQ(places["rows"].size(), 1u);
  const std::string acts = places["rows"][0];
  EXPECT_TRUE(acts == "every bushing" || acts.rfind("bushing:", 0) == 0)
      << acts;
  for (size_t j = 0; j < places["columns"].size(); ++j) {
    EXPECT_EQ(places["counts"][0][j],
              written["component_confusion"][acts].value(
                  places["columns"][j].get<std::string>(), 0));
  }
  EXPECT_EQ(page["power"], written["power"]);
  ASSERT_EQ(page["cases"].size(), 2u);
  EXPECT_EQ(page["cases"][1]["truth"], "none");
  EXPECT_EQ(page["cases"][0]["size_sigma"],
            written["case_results"][0]["size_sigma"]);
}

// A validate.json as kcrig validate writes it, by hand (no validation run:
// this one runs under the sanitizers), then broken in one place at a time:
// one line naming the field, no page.
TEST_F(ReportCliTest, ABrokenValidateJsonIsOneLineNamingTheField) {
  const std::string dir = Path("validation");
  fs::create_directories(dir);
  const Json written = Json::parse(R"({"seed": 1,
    "confusion_rows": ["hysteresis", "none"],
    "confusion_columns": ["none", "hysteresis", "pair", "unexplained"],
    "confusion": {"hysteresis": {"hysteresis": 1}, "none": {"none": 1}},
    "component_confusion": {"bushing:V1": {"bushing:V1": 1}},
    "power": {"hysteresis": {"bins": [{"from_sigma": 3, "to_sigma": 5,
                                       "cases": 1, "detected": 1}],
                             "smallest_detected_sigma": 4.2}},
    "figures": {"library_effects_beyond_3_sigma": {"correct": 1, "total": 1},
                "clean": {"none": 1, "total": 1},
                "wrong_parameters_beyond_3_sigma": {"named": 0, "total": 0},
                "gap_closed_80_percent_when_correct": {"closed": 1,
                                                       "total": 1},
                "confident_wrong": 0},
    "case_results": [
      {"truth": "hysteresis", "verdict": "hysteresis", "size_sigma": 4.2,
       "correct": true, "confident_wrong": false},
      {"truth": "none", "verdict": "none", "size_sigma": 0,
       "correct": true, "confident_wrong": false}]})");
  std::ofstream(dir + "/validate.json") << written.dump();
  const CliResult good =
      RunKcrig("report --from " + dir + " --quiet --out " + Path("r.html"));
  ASSERT_EQ(good.exit_code, 0) << good.output;
  EXPECT_NE(good.output.find("4 figures (0 experiments, validation)"),
            std::string::npos)
      << good.output;
  auto refused = [&](const std::function<void(Json*)>& breakage,
                     const std::string& what) {
    Json doc = written;
    breakage(&doc);
    std::ofstream(dir + "/validate.json") << doc.dump();
    const CliResult bad =
        RunKcrig("report --from " + dir + " --quiet --out " + Path("bad.html"));
    EXPECT_EQ(bad.exit_code, 1) << what;
    EXPECT_EQ(CountLines(bad.output), 1) << bad.output;
    EXPECT_NE(bad.output.find(what), std::string::npos) << bad.output;
    EXPECT_FALSE(fs::exists(Path("bad.html"))) << what;
  };
  refused([](Json* d) { (*d)["confusion"]["none"]["maybe"] = 1; },
          "validate.json.confusion.none.maybe: expected a count");
  refused([](Json* d) { (*d)["confusion"]["none"]["none"] = "1"; },
          "validate.json.confusion.none.none: expected a count");
  refused([](Json* d) { (*d)["case_results"][1].erase("size_sigma"); },
          "case_results[1]: missing field 'size_sigma'");
  refused([](Json* d) { (*d)["figures"]["clean"].erase("total"); },
          "validate.json.figures.clean: missing field 'total'");
  refused([](Json* d) { d->erase("confusion_rows"); },
          "validate.json: missing field 'confusion_rows'");
  refused([](Json* d) { (*d)["component_confusion"] = 3; },
          "validate.json.component_confusion: expected an object");
}

// Every failure is one line naming what is wrong, and no report is left.
void ExpectRefused(const std::string& args, const std::string& what,
                   const std::string& out) {
  // A small surface grid: the errors come after the surfaces.
  const std::string grid =
      args.find("--grid") == std::string::npos ? " --grid 2x2" : "";
  const CliResult r =
      RunKcrig("report " + args + grid + " --quiet --out " + out);
  EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.output;
  EXPECT_EQ(CountLines(r.output), 1) << r.output;
  EXPECT_NE(r.output.find(what), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out)) << args;
}

TEST_F(ReportCliTest, BadFoldersAreOneLineErrorsAndWriteNothing) {
  const std::string out = Path("r.html");
  ExpectRefused("--from " + Path("missing"), "missing: not a folder", out);
  fs::create_directories(Path("empty"));
  ExpectRefused("--from " + Path("empty"),
                "no campaign.json, diag.json, timing.json or validate.json",
                out);
  const std::string& campaign = Campaign(kNothingMore);
  ExpectRefused("--from " + campaign + " --grid 19", "--grid 19", out);
  ExpectRefused("--from " + campaign + " --grid 1x5", "--grid 1x5", out);

  // A copy of the campaign, broken in one place at a time.
  const std::string copy = Path("copy");
  auto fresh = [&] {
    fs::remove_all(copy);
    fs::copy(campaign, copy, fs::copy_options::recursive);
  };
  fresh();
  const std::string summary = copy + "/campaign.json";
  std::string text = ReadText(summary);
  std::ofstream(summary) << text.substr(0, text.size() / 2);
  ExpectRefused("--from " + copy, "campaign.json: not valid JSON", out);

  Json doc = Json::parse(text);
  doc["iterations"][1].erase("parameters");
  std::ofstream(summary) << doc.dump();
  ExpectRefused("--from " + copy,
                "campaign.json: iterations[1]: missing field 'parameters'",
                out);

  doc = Json::parse(text);
  doc["iterations"][0]["experiment"]["phi_deg"] = "85";
  std::ofstream(summary) << doc.dump();
  ExpectRefused("--from " + copy, "iterations[0].experiment.phi_deg", out);

  fresh();
  fs::remove(copy + "/iteration_1/run.csv");
  ExpectRefused("--from " + copy, "iteration_1/run.csv", out);

  fresh();
  std::ofstream(copy + "/iteration_1/isolability.json")
      << "{\"candidates\": [\"a\"], \"min_share_left\": 0.2, "
         "\"left\": [[0, 1]]}";
  ExpectRefused("--from " + copy, "iteration_1/isolability.json.left", out);

  fresh();
  std::ofstream(copy + "/diag.json") << "{\"verdict\": 3}";
  ExpectRefused("--from " + copy, "diag.json", out);

  fresh();
  std::ofstream(copy + "/timing.json") << "{\"period_us\": 1000}";
  ExpectRefused("--from " + copy, "timing.json: missing field 'phases'", out);

  // Files of an unexpected shape are errors naming them, never a crash.
  fresh();
  std::ofstream(copy + "/timing.json")
      << "{\"period_us\": 1000, \"phases\": {}, \"budget\": null}";
  ExpectRefused("--from " + copy, "timing.json: unexpected content", out);
  fresh();
  std::ofstream(copy + "/diag.json")
      << "{\"verdict\": \"none\", \"reason\": \"r\", \"localisation\": 7}";
  ExpectRefused("--from " + copy, "diag.json: unexpected content", out);
  fresh();
  doc = Json::parse(text);
  doc["iterations"][0]["parameters"] = "c_O1";
  std::ofstream(summary) << doc.dump();
  ExpectRefused("--from " + copy, "campaign.json", out);

  // Whole again, with a well-formed isolability matrix of its own, the copy
  // renders: each refusal above was its breakage.
  fresh();
  std::ofstream(copy + "/iteration_1/isolability.json")
      << "{\"candidates\": [\"a\", \"b\"], \"min_share_left\": 0.2, "
         "\"left\": [[null, 0.5], [0.1, null]]}";
  const CliResult r =
      RunKcrig("report --from " + copy + " --grid 2x2 --quiet --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("10 figures (2 experiments, campaign)"),
            std::string::npos)
      << r.output;
  const Json data = PageData(ReadText(out));
  EXPECT_EQ(data["expected_figures"], 10);
  EXPECT_EQ(data["isolability"]["left"][1][0], 0.1);
}

// The surfaces are the objective the campaign's optimizer searched: at the
// designed experiment of each iteration, the second one's prior being the
// information of two logs (est.json), the report's criterion is the value
// its design.json recorded.
TEST(ReportSurfacesTest, AreTheObjectiveTheCampaignSearched) {
  const fs::path dir = fs::temp_directory_path() /
                       ("kcrig_report_surfaces_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const std::string campaign = (dir / "campaign").string();
  const CliResult run = RunKcrig(
      "campaign --iterations 2 --budget 12 --quiet --no-report --out " +
      campaign);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const std::string html = (dir / "report.html").string();
  const CliResult r = RunKcrig("report --from " + campaign +
                               " --grid 3x2 --quiet --out " + html);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // 3 experiments, sensitivities, estimates, D and A of 2 designs, kriging,
  // 3 K&C loops (no isolability: not asked for).
  EXPECT_NE(r.output.find("13 figures (3 experiments, campaign)"),
            std::string::npos)
      << r.output;
  const Json data = PageData(ReadText(html));
  ASSERT_EQ(data["surfaces"].size(), 4u);
  for (int k = 0; k < 2; ++k) {
    const std::string iteration = "iteration_" + std::to_string(k);
    const Json design =
        Json::parse(std::ifstream(campaign + "/" + iteration + "/design.json"));
    const Json& surface = data["surfaces"][2 * k];
    EXPECT_EQ(surface["iteration"], iteration);
    EXPECT_EQ(surface["criterion"], "D");
    EXPECT_NEAR(surface["optimum"]["phi_deg"].get<double>(),
                design["optimal"]["phi_deg"].get<double>(), 1e-12);
    EXPECT_EQ(surface["optimum"]["z_a"], design["optimal"]["z_a"]);
    const double recorded = design["optimal"]["value"];
    EXPECT_NEAR(surface["optimum"]["value"].get<double>(), recorded,
                1e-9 * std::abs(recorded))
        << iteration;
    EXPECT_EQ(surface["runs"][0]["evaluated"].size(),
              design["runs"][0]["evaluated"].size());
  }
  fs::remove_all(dir);
}

// Text from the files (a diagnosis reason here) cannot end the page's data
// script or open a comment in it: the data reads back intact.
TEST_F(ReportCliTest, MarkupInTheFilesCannotBreakThePage) {
  const std::string dir = Path("markup");
  fs::create_directories(dir);
  std::ofstream(dir + "/diag.json") << R"({"verdict": "none",
    "reason": "</script><!--<script> /*KCRIG_PAGE_SCRIPT*/"})";
  const CliResult r =
      RunKcrig("report --from " + dir + " --quiet --out " + Path("r.html"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string html = ReadText(Path("r.html"));
  EXPECT_EQ(html.find("</script><!--"), std::string::npos);
  const Json data = PageData(html);
  EXPECT_EQ(data["diagnoses"][0]["reason"],
            "</script><!--<script> /*KCRIG_PAGE_SCRIPT*/");
}

}  // namespace
}  // namespace kcrig
