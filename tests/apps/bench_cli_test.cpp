// tet2spline_bench (README "Benchmarks"): the whole-pipeline mode runs
// convert per repetition and reports every stage of its report, the OT
// iterations and the child's peak memory; a failing model is reported with
// convert's exit status; options after `--` reach convert.
#include <gtest/gtest.h>

#include <cmath>

#include "cli_runner.h"

using t2stest::q;

TEST(Bench, PipelineReportsEveryStageAndConvertOptionsReachConvert) {
  const auto dir = t2stest::scratchDir("bench_pipeline");
  const auto json = dir / "bench.json";
  const auto r = t2stest::runProgram(t2stest::sibling("tet2spline_bench"),
                                     "--data " + q(t2stest::dataDir()) + " blob-closed --repeat 2 --json " + q(json) +
                                         " -- --elements 2 --degree 2",
                                     dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("blob-closed"), std::string::npos) << r.out;
  const auto j = t2stest::readJson(json);
  ASSERT_EQ(j["models"].size(), 1u);
  const auto& m = j["models"][0];
  EXPECT_EQ(m["runs"], 2);
  EXPECT_EQ(m["failed_runs"], 0);
  for (const char* stage : {"load", "spherical_map", "transport", "final_untangle", "fit", "export", "total"}) {
    ASSERT_TRUE(m["timings"].contains(stage)) << stage;
    EXPECT_GE(m["timings"][stage].get<double>(), 0) << stage;
  }
  EXPECT_LE(m["timings"]["fit"].get<double>(), m["timings"]["total"].get<double>());
  EXPECT_GT(m["ot_iterations"].get<int>(), 0);
  EXPECT_GT(m["peak_rss_mib"].get<double>(), 10);
  EXPECT_EQ(m["param_inverted_tets"], 0);
  EXPECT_GT(m["wall_seconds"].get<double>(), 0);
  EXPECT_FALSE(m.contains("growth"));  // (one model: nothing to grow from)
}

// Two models: the second's growth from the first, total against n log n.
TEST(Bench, GrowthIsReportedFromTheFirstModel) {
  const auto dir = t2stest::scratchDir("bench_growth");
  const auto json = dir / "bench.json";
  const auto r = t2stest::runProgram(t2stest::sibling("tet2spline_bench"),
                                     "--data " + q(t2stest::dataDir()) + " blob-closed blobby --repeat 1 --json " +
                                         q(json) + " -- --elements 2 --degree 2",
                                     dir);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("growth blob-closed -> blobby"), std::string::npos) << r.out;
  const auto j = t2stest::readJson(json);
  const auto& a = j["models"][0];
  const auto& b = j["models"][1];
  ASSERT_TRUE(b.contains("growth"));
  const double n0 = a["param_tets"].get<double>(), n1 = b["param_tets"].get<double>();
  EXPECT_DOUBLE_EQ(b["growth"]["tets"].get<double>(), n1 / n0);
  EXPECT_NEAR(b["growth"]["n_log_n"].get<double>(), n1 * std::log(n1) / (n0 * std::log(n0)), 1e-12);
  EXPECT_NEAR(b["growth"]["total"].get<double>(), b["timings"]["total"].get<double>() / a["timings"]["total"].get<double>(), 1e-12);
  EXPECT_NEAR(b["growth"]["total_over_n_log_n"].get<double>(),
              b["growth"]["total"].get<double>() / b["growth"]["n_log_n"].get<double>(), 1e-12);
}

TEST(Bench, AFailingModelGivesConvertsStatusAndItsMessage) {
  const auto dir = t2stest::scratchDir("bench_failing");
  const auto json = dir / "bench.json";
  const auto r = t2stest::runProgram(t2stest::sibling("tet2spline_bench"),
                                     "--data " + q(t2stest::dataDir()) + " elephant --repeat 3 --json " + q(json), dir);
  EXPECT_EQ(r.status, 4) << r.out << r.err;  // genus > 0: unsupported topology
  const auto j = t2stest::readJson(json);
  const auto& m = j["models"][0];
  EXPECT_EQ(m["runs"], 1);  // not repeated
  EXPECT_EQ(m["exit_status"], 4);
  EXPECT_NE(m["error"].get<std::string>().find("genus"), std::string::npos) << m["error"];
  // Options after -- belong to convert: the ball-map stage refuses them.
  EXPECT_EQ(t2stest::runProgram(t2stest::sibling("tet2spline_bench"), "--stage ball blob-closed -- --elements 2", dir).status, 2);
}

// --perturb: run k converts the model scaled by 1 + k·1e-9 (README
// "Benchmarks"); each run's total and figures are listed and the medians lie
// within their spread. CAD inputs cannot be scaled that way (usage, 2), and
// the ball stage takes no --perturb.
TEST(Bench, PerturbedRunsAreListedWithTheirSpread) {
  const auto dir = t2stest::scratchDir("bench_perturb");
  const auto json = dir / "bench.json";
  const auto tmp = dir / "tmp";  // the bench's TMPDIR: its scaled copies go there
  std::filesystem::create_directories(tmp);
  ::setenv("TMPDIR", tmp.c_str(), 1);
  const auto r = t2stest::runProgram(t2stest::sibling("tet2spline_bench"),
                                     "--data " + q(t2stest::dataDir()) + " blob-closed --repeat 2 --perturb --json " +
                                         q(json) + " -- --elements 2 --degree 2",
                                     dir);
  ASSERT_EQ(r.status, 0) << r.err;
  const auto j = t2stest::readJson(json);
  EXPECT_EQ(j["perturb"], true);
  const auto& m = j["models"][0];
  ASSERT_EQ(m["per_run"].size(), 2u);
  for (const auto& run : m["per_run"]) {
    EXPECT_GT(run["ot_iterations"].get<int>(), 0);
    EXPECT_GT(run["fit_rms_error_relative"].get<double>(), 0);
    EXPECT_TRUE(run.contains("morph"));
  }
  const double lo = m["total_min"], hi = m["total_max"], mid = m["timings"]["total"];
  EXPECT_LE(lo, mid);
  EXPECT_LE(mid, hi);
  EXPECT_EQ(t2stest::runProgram(t2stest::sibling("tet2spline_bench"),
                                "--perturb --repeat 2 " + q(t2stest::sourceDir() + "/models/bracket.step"), dir)
                .status,
            2);
  EXPECT_EQ(t2stest::runProgram(t2stest::sibling("tet2spline_bench"), "--stage ball --perturb blob-closed", dir).status, 2);
  ::unsetenv("TMPDIR");
  // No scaled copies (nor run folders) are left behind.
  EXPECT_TRUE(std::filesystem::is_empty(tmp)) << t2stest::listDir(tmp).front();
}
