// The report in a real browser: a campaign (which writes its report), a
// timing check and a diagnosis in one folder, `kcrig report` over it, and
// headless Chromium opening the page. The page records how many figures it
// created, how many plotly rendered (an SVG with drawn traces) and every
// error (uncaught or console.error); the test reads that from the DOM and
// keeps a screenshot in the build tree (report_screenshot.png).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "gtest/gtest.h"
#include "tests/support/cli_runner.h"
#include "tests/support/temp_dir_test.h"

namespace kcrig {
namespace {

namespace fs = std::filesystem;

// Width and height from a PNG's IHDR chunk (0 when not a PNG).
std::pair<std::uint32_t, std::uint32_t> PngSize(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char header[24] = {};
  in.read(reinterpret_cast<char*>(header), sizeof(header));
  if (!in || header[1] != 'P' || header[2] != 'N' || header[3] != 'G') {
    return {0, 0};
  }
  auto be32 = [&](int at) {
    return static_cast<std::uint32_t>(header[at]) << 24 |
           static_cast<std::uint32_t>(header[at + 1]) << 16 |
           static_cast<std::uint32_t>(header[at + 2]) << 8 | header[at + 3];
  };
  return {be32(16), be32(20)};
}

// An attribute's value in the status element of the dumped DOM.
std::string Attribute(const std::string& dom, const std::string& name) {
  const size_t element = dom.find("id=\"kcrig-status\"");
  if (element == std::string::npos) return "";
  const size_t end = dom.find('>', element);
  const std::string tag = dom.substr(element, end - element);
  const size_t at = tag.find(name + "=\"");
  if (at == std::string::npos) return "";
  const size_t begin = at + name.size() + 2;
  return tag.substr(begin, tag.find('"', begin) - begin);
}

class ReportBrowserTest : public TempDirTest {};

TEST_F(ReportBrowserTest, EveryFigureRendersInHeadlessChromium) {
  const std::string dir = Path("campaign");
  CliResult r = RunKcrig(
      "campaign --iterations 1 --budget 12 --isolability --quiet "
      "--out " +
      dir);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("report with 10 figures: " + dir + "/report.html"),
            std::string::npos)
      << r.output;
  ASSERT_TRUE(fs::exists(dir + "/report.html"));

  // The loop's timing on this machine; exit 4 is "over budget", which a
  // shared machine may be, and the report shows then.
  r = RunKcrig("timing-check --duration 1 --baseline 0.5 --quiet --out " + dir +
               "/timing.json");
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 4) << r.output;
  for (const auto& [name, args] :
       {std::pair<std::string, std::string>{"a", "--phi 85 --z -0.45"},
        {"b", "--phi 10 --z -0.1"},
        {"h", "--phi 45 --z -0.3"}}) {
    r = RunKcrig("simulate --noise --seed 5 " + args +
                 " --effect hysteresis --duration 1.5 --hold 0.3 --return 1 "
                 "--out " +
                 dir + "/" + name + ".csv");
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  r = RunKcrig("diagnose --quiet --log " + dir + "/a.csv --log " + dir +
               "/b.csv --holdout " + dir + "/h.csv --out " + dir +
               "/diag.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunKcrig(
      "validate --quiet --cases 2 --effects bushing_damping,none --out " + dir +
      "/validate.json");
  ASSERT_EQ(r.exit_code, 0) << r.output;

  // The same timing under a folder whose name is markup: its figure title
  // must show it as text (plotly would draw a link and bold type).
  const std::string markup = "<a href=https:evil.example>link <b>bold";
  fs::create_directories(dir + "/" + markup);
  fs::copy_file(dir + "/timing.json", dir + "/" + markup + "/timing.json");

  r = RunKcrig("report --from " + dir + " --quiet");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // 10 campaign figures (2 of them the K&C loops, one the isolability), 3
  // of the diagnosis, 2 of the timing, 4 of the validation (with the
  // bushing effect's places).
  ASSERT_NE(r.output.find("19 figures"), std::string::npos) << r.output;

  const std::string screenshot =
      std::string(KCRIG_TEST_ARTIFACT_DIR) + "/report_screenshot.png";
  fs::remove(screenshot);
  const std::string dom_file = Path("dom.html");
  // --virtual-time-budget lets the page's scripts run to completion
  // before the DOM is dumped and the screenshot taken.
  // In a subshell: Chromium's own stderr (console messages, crashes) comes
  // back in r.output, the DOM goes to the file.
  r = RunCommand(
      "(chromium --headless=new --no-sandbox --disable-gpu "
      "--disable-dev-shm-usage --hide-scrollbars --no-first-run "
      "--virtual-time-budget=60000 --window-size=1400,10000 "
      "--screenshot=" +
      screenshot + " --dump-dom file://" + dir + "/report.html > " + dom_file +
      ")");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dom_file);
  const std::string dom((std::istreambuf_iterator<char>(in)),
                        std::istreambuf_iterator<char>());
  ASSERT_NE(dom.find("id=\"kcrig-status\""), std::string::npos)
      << dom.substr(0, 2000);
  EXPECT_EQ(Attribute(dom, "data-state"), "done");
  EXPECT_EQ(Attribute(dom, "data-expected"), "19");
  EXPECT_EQ(Attribute(dom, "data-figures"), "19");
  EXPECT_EQ(Attribute(dom, "data-rendered"), "19");
  // The page opens with its summary: the campaign's outcome, its final
  // estimates and checks, the diagnosis' verdict, the K&C sheet's agreement
  // and the loop's budget, before the first time history.
  const size_t summary = dom.find("<h2>Summary</h2>");
  ASSERT_NE(summary, std::string::npos);
  EXPECT_LT(summary, dom.find("<h2>Experiments: measured vs model</h2>"));
  EXPECT_EQ(dom.find("<section"), dom.find("<section id=\"summary\">"));
  for (const char* line :
       {"Campaign: 2 iterations; final model: ", ">Final estimates</h3>",
        ">Checks and actions per iteration</h3>", "Diagnosis (",
        "K&amp;C sheet: model and rig", "Loop timing ("}) {
    const size_t at = dom.find(line, summary);
    EXPECT_NE(at, std::string::npos) << line;
    EXPECT_LT(at, dom.find("<h2>Experiments: measured vs model</h2>")) << line;
  }
  // The K&C sheet's tables: per run the channels, the standard figures and
  // the compliance matrix.
  EXPECT_NE(dom.find(">K&amp;C sheet</h2>"), std::string::npos);
  EXPECT_NE(dom.find(">lateral force steer</td>"), std::string::npos);
  EXPECT_NE(dom.find("Wheel-centre compliance matrix"), std::string::npos);
  EXPECT_EQ(Attribute(dom, "data-errors"), "[]");
  // The markup is drawn as its characters: no link, no bold element.
  EXPECT_NE(dom.find("&lt;a href=https:evil.example&gt;link &lt;b&gt;bold"),
            std::string::npos);
  EXPECT_EQ(dom.find("evil.example\""), std::string::npos);
  EXPECT_EQ(dom.find(">bold<"), std::string::npos);
  // Chromium's own log of the page's console (beside the page's record).
  EXPECT_EQ(r.output.find("Uncaught"), std::string::npos) << r.output;

  const auto [width, height] = PngSize(screenshot);
  EXPECT_EQ(width, 1400u);
  EXPECT_EQ(height, 10000u);
  // A blank page of that size compresses to a few kB; the figures do not.
  EXPECT_GT(fs::file_size(screenshot), 500u * 1024u);
}

}  // namespace
}  // namespace kcrig
