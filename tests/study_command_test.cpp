// `kgd study accuracy` as a user runs it, in its quick mode on the smallest scene that has every part
// the study can run there (the pull test: designs, methods, the Newton/L-BFGS traces, the jaw force):
// the generated document and its data, checked for what they must say, not for timings.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/kgd_cli.h"

namespace kgd {
namespace {

namespace fs = std::filesystem;

using Row = std::map<std::string, std::string>;

// A CSV file as rows keyed by the header's names (quoted fields may hold commas).
std::vector<Row> ReadCsv(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> lines;
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> fields(1);
    bool quoted = false;
    for (char c : line) {
      if (c == '"') {
        quoted = !quoted;
      } else if (c == ',' && !quoted) {
        fields.emplace_back();
      } else {
        fields.back() += c;
      }
    }
    lines.push_back(fields);
  }
  std::vector<Row> rows;
  for (size_t i = 1; i < lines.size(); ++i) {
    Row r;
    for (size_t k = 0; k < lines[0].size() && k < lines[i].size(); ++k) r[lines[0][k]] = lines[i][k];
    rows.push_back(r);
  }
  return rows;
}

double Number(const Row& r, const std::string& key) { return r.count(key) ? std::stod(r.at(key)) : std::nan(""); }

TEST(StudyCommand, QuickStudyOfThePullTestWritesItsDocumentAndData) {
  const fs::path out = fs::temp_directory_path() / "kgd_study_command" / "quick";
  fs::remove_all(out);
  const auto run = cli_test::Kgd("study accuracy pull_test_line --quick --out " + out.string() +
                                 " --method-iterations 3 --lbfgs-trace-iterations 200");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* file : {"ACCURACY.md", "runs.csv", "traces.csv", "pull_test.csv", "frames.csv", "accuracy_time.svg", "newton_lbfgs.svg"})
    EXPECT_TRUE(fs::exists(out / file)) << file;

  std::ifstream md_file(out / "ACCURACY.md");
  const std::string md((std::istreambuf_iterator<char>(md_file)), {});
  for (const char* section : {"do not edit by hand", "## Presets", "## Design jobs", "## Methods over the first 3 iterations",
                              "## Newton against L-BFGS on one solve", "## The pull test's force", "## The frames a design is evaluated over",
                              "| draft | 1e-03 |", "| standard | 1e-04 |", "| precise | 1e-06 |", "not a paper scene"})
    EXPECT_NE(md.find(section), std::string::npos) << section << " missing from:\n" << md;
  for (const char* undefined : {" nan ", " -nan ", " inf ", " -inf "})
    EXPECT_EQ(md.find(undefined), std::string::npos) << "no undefined number in the document:\n" << md;
  // A method that never reached an error of the Newton/L-BFGS table shows a dash there, and the document
  // says what a dash means exactly when one is shown.
  const size_t versus = md.find("## Newton against L-BFGS on one solve"), versus_end = md.find("Ends: ", versus);
  ASSERT_NE(versus_end, std::string::npos);
  const std::string versus_table = md.substr(versus, versus_end - versus);
  EXPECT_EQ(versus_table.find("| - |") != std::string::npos, versus_table.find("A dash: ") != std::string::npos) << versus_table;

  // Every design run: a design denser than the fully reinforced garment, agreement indices in [0, 1],
  // the reference run agreeing with itself.
  const std::vector<Row> runs = ReadCsv(out / "runs.csv");
  std::map<std::string, int> knobs;
  for (const Row& r : runs) {
    ++knobs[r.at("knob")];
    EXPECT_GT(Number(r, "per_iteration_s"), 0) << r.at("knob") << " " << r.at("value");
    EXPECT_GT(Number(r, "ratio_tight"), 1.0) << r.at("knob") << " " << r.at("value");
    EXPECT_GE(Number(r, "jaccard"), 0.0);
    EXPECT_LE(Number(r, "jaccard"), 1.0);
    if (r.at("knob") == "grad_tol" && r.at("value") == "1e-06") {
      EXPECT_EQ(Number(r, "jaccard_precise"), 1.0);
    }
  }
  EXPECT_EQ(knobs["grad_tol"], 3) << "the quick mode's three tolerances";
  EXPECT_EQ(knobs["method"], 3) << "Newton, L-BFGS to the tolerance, L-BFGS with the paper's budget";
  EXPECT_EQ(knobs["relaxation"], 1);
  EXPECT_EQ(knobs["fold_barrier"], 1);

  // Newton's energy trace from the cold start only falls (a line search accepts no rise).
  const std::vector<Row> traces = ReadCsv(out / "traces.csv");
  double last = INFINITY;
  int newton_cold = 0;
  for (const Row& r : traces) {
    if (r.at("trace") != "Newton, cold") continue;
    ++newton_cold;
    EXPECT_LE(Number(r, "energy_J"), last * (1 + 1e-12));
    last = Number(r, "energy_J");
  }
  EXPECT_GT(newton_cold, 2);

  // The jaw force converges with the tolerance: the tightest errors are tiny and none grows.
  const std::vector<Row> pull = ReadCsv(out / "pull_test.csv");
  ASSERT_GE(pull.size(), 5u);
  for (size_t i = 1; i < pull.size(); ++i)
    EXPECT_LE(Number(pull[i], "relative_error"), Number(pull[i - 1], "relative_error") * (1 + 1e-9)) << pull[i].at("grad_tol");
  EXPECT_LT(Number(pull.back(), "relative_error"), 1e-6);
}

}  // namespace
}  // namespace kgd
