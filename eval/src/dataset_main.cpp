// holofuse_dataset: checks and describes datasets (recordings and imports).
//   holofuse_dataset verify DIR     exit 0 clean, 3 incomplete tail, 1 corrupt, 2 unusable
//   holofuse_dataset info DIR [--sheet PNG] [--voxel M]
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>

#include "eval/dataset_inspection.h"

int main(int argc, char** argv) {
  using namespace holofuse;
  CLI::App app{"holofuse dataset: verify and describe recorded or imported datasets"};
  app.require_subcommand(1);
  std::string dir, sheet;
  double voxel = 0.02;
  auto* verify = app.add_subcommand("verify", "check every record; name the bytes a crash left incomplete");
  verify->add_option("dir", dir, "dataset folder")->required();
  auto* info = app.add_subcommand("info", "cameras, frames, sizes, codecs, silhouette IoU and a contact sheet");
  info->add_option("dir", dir, "dataset folder")->required();
  info->add_option("--sheet", sheet, "contact sheet PNG (default DIR/contact_sheet.png)");
  info->add_option("--voxel", voxel, "hull voxel size in metres")->check(CLI::Range(0.002, 0.5));
  CLI11_PARSE(app, argc, argv);
  if (verify->parsed()) {
    auto report = eval::verifyDataset(dir);
    if (!report.isOk()) {
      std::fprintf(stderr, "dataset verify: %s\n", report.status().message().c_str());
      return 2;
    }
    std::printf("%s", report->text.c_str());
    return static_cast<int>(report->verdict);
  }
  if (sheet.empty()) sheet = (std::filesystem::path(dir) / "contact_sheet.png").string();
  auto summary = eval::describeDataset(dir, sheet, voxel);
  if (!summary.isOk()) {
    std::fprintf(stderr, "dataset info: %s\n", summary.status().message().c_str());
    return 2;
  }
  std::printf("%s", summary->text.c_str());
  return 0;
}
