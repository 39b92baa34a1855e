// hexsim batch-report DIR [--json FILE] [--no-plots]   (table on stdout, report.json, report.png, report.html)
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "cli_util.h"
#include "commands.h"
#include "hexsim/batch/report.h"
#include "hexsim/batch/results_db.h"
#include "hexsim/common/atomic_file.h"
#include "hexsim/common/paths.h"
#include "hexsim/experiments/batch_flow.h"
#include "hexsim/reports/batch_report.h"
#include "hexsim/reports/headline.h"

namespace hexsim::app {

namespace {

namespace fs = std::filesystem;

struct ReportArgs {
  std::string dir;
  std::string json_path;
  bool plots = true;
};

Status ReportCommand(const ReportArgs& args, int* exit_code) {
  const std::string db_path = fs::is_regular_file(args.dir) ? args.dir : args.dir + "/" + experiments::kResultsFile;
  std::error_code ec;
  if (!fs::is_regular_file(db_path, ec)) return Status::BadInput(db_path + ": no such results file");
  auto db = batch::ResultsDb::Open(db_path, /*create=*/false);
  if (!db.ok()) return db.status();
  auto rows = db->ReadAll();
  if (!rows.ok()) return rows.status();
  if (rows->empty()) return Status::BadInput(db_path + ": holds no runs");
  const auto groups = batch::AggregateRuns(*rows);
  for (const std::string& sentence : reports::BatchHeadline(groups)) std::printf("%s\n", sentence.c_str());
  std::fputs(reports::NumberedReportTable(groups).c_str(), stdout);
  const std::string dir = fs::is_directory(args.dir) ? args.dir : DirName(db_path);
  const std::string json_path = args.json_path.empty() ? dir + "/report.json" : args.json_path;
  HEXSIM_RETURN_IF_ERROR(WriteFileAtomic(json_path, batch::ReportJson(groups).dump(2) + "\n"));
  *exit_code = 0;
  bool figure = false;
  if (args.plots) {
    const Status s = reports::WriteBatchReportFigure(groups, dir + "/report.png");
    figure = s.ok();
    if (!s.ok()) {
      std::fprintf(stderr, "hexsim: batch-report: plots not written: %s\n", s.message().c_str());
      *exit_code = 1;
    }
  }
  return reports::WriteBatchReportHtml(groups, figure ? "report.png" : "", dir + "/report.html");
}

}  // namespace

void AddBatchReportCommand(CLI::App& app, int* exit_code) {
  auto rargs = std::make_shared<ReportArgs>();
  CLI::App* rep = app.add_subcommand("batch-report", "Aggregate a batch's results per group: table, report.json, report.png, report.html");
  rep->add_option("dir", rargs->dir, "Batch output directory (or a results.sqlite)")->required();
  rep->add_option("--json", rargs->json_path, "Write the JSON here (default DIR/report.json)");
  rep->add_flag("!--no-plots", rargs->plots, "Skip report.png");
  rep->callback([rargs, exit_code] {
    const Status s = ReportCommand(*rargs, exit_code);
    if (!s.ok()) *exit_code = Report(s);
  });
}

}  // namespace hexsim::app
