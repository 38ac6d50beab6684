// holofuse_dataset: checks and describes datasets (recordings and imports).
//   holofuse_dataset verify DIR     exit 0 clean, 3 incomplete tail, 1 corrupt, 2 unusable
//   holofuse_dataset info DIR [--sheet PNG] [--voxel M] [--health-frames N]
//   holofuse_dataset import SRC --format F --out DIR [segmentation flags]
//   holofuse_dataset export DIR --out FILE.glb|FILE.obj [--frame ID] [--atlas-size N]
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "config/command_line.h"
#include "dataset/import.h"
#include "dataset/inspection.h"
#include "dataset/textured_export.h"
#include "hull/visual_hull.h"
#include "texture/texture_atlas.h"

namespace {

// One line, redrawn in place on a terminal, every 10% otherwise.
void printProgress(const holofuse::dataset::ImportProgress& p) {
  static size_t last_decile = 0;
  const bool tty = isatty(STDERR_FILENO) != 0;
  const size_t decile = p.total ? 10 * p.done / p.total : 10;
  if (!tty && decile == last_decile && p.done != p.total) return;
  last_decile = decile;
  const double rate = p.seconds > 0 ? static_cast<double>(p.done) / p.seconds : 0.0;
  const double eta = rate > 0 ? static_cast<double>(p.total - p.done) / rate : 0.0;
  const int filled = p.total ? static_cast<int>(20 * p.done / p.total) : 20;
  std::fprintf(stderr, "%s[import] |%.*s%*s| %zu/%zu images, %.1f MB, %.1f images/s, ETA %.0f s%s",
               tty ? "\r" : "", filled, "####################", 20 - filled, "", p.done, p.total,
               p.megabytes, rate, eta, tty && p.done != p.total ? "" : "\n");
}

}  // namespace

int main(int argc, char** argv) {
  using namespace holofuse;
  CLI::App app{"holofuse dataset: verify and describe recorded or imported datasets"};
  app.require_subcommand(1);
  std::string dir, sheet;
  double voxel = 0.02;
  auto* verify =
      app.add_subcommand("verify", "check every record; name the bytes a crash left incomplete");
  verify->add_option("dir", dir, "dataset folder")->required();
  auto* info = app.add_subcommand(
      "info", "cameras, frames, sizes, codecs, silhouette IoU and a contact sheet");
  info->add_option("dir", dir, "dataset folder")->required();
  info->add_option("--sheet", sheet, "contact sheet PNG (default DIR/contact_sheet.png)");
  size_t health_frames = 16;
  info->add_option("--health-frames", health_frames,
                   "frames, spread through the dataset, on which each camera's mask health over "
                   "time is measured (0: every frame)")
      ->capture_default_str();
  info->add_option("--voxel", voxel, "hull voxel size in metres (default: the dataset's)")
      ->check(CLI::Range(holofuse::hull::kMinVoxel, holofuse::hull::kMaxVoxel));
  auto* import =
      app.add_subcommand("import", "convert a real multi-view capture into a dataset that replays");
  std::string source, format, out;
  dataset::ImportOptions import_options;
  double threshold = -1, import_voxel = -1;
  import->add_option("source", source, "capture folder")->required();
  import
      ->add_option("--format", format,
                   std::string("capture format: ") + dataset::captureFormatNames())
      ->required();
  import->add_option("--out", out, "dataset folder to create (must not exist or be empty)")
      ->required();
  import
      ->add_option("--threshold", threshold,
                   "segment by brightness above this (0..1) where masks are missing; "
                   "default Otsu's threshold")
      ->check(CLI::Range(0.0, 1.0));
  import->add_flag("--dark-subject", import_options.dark_subject,
                   "the subject is darker than the background");
  import->add_option("--close-px", import_options.close_px, "closing radius after thresholding")
      ->check(CLI::Range(0, 100));
  import
      ->add_option("--mask-threshold", import_options.mask_threshold,
                   "a mask pixel is the subject above this share of its range (brightest colour "
                   "channel, grey or alpha), so masks saved through video or JPEG keep their "
                   "shape")
      ->check(CLI::Range(0.001, 0.999));
  import
      ->add_option("--exclude-cameras", import_options.exclude_cameras,
                   "leave these cameras out, by their names in the source (comma separated)")
      ->delimiter(',');
  bool no_rig_agreement = false;
  import->add_flag("--no-rig-agreement", no_rig_agreement,
                   "keep each segmented mask as its camera saw it (by default, with 3 cameras or "
                   "more, what the other cameras' hull does not explain is cut)");
  import->add_option("--voxel", import_voxel, "hull voxel size for replays (default: volume / 96)")
      ->check(CLI::Range(holofuse::hull::kMinVoxel, holofuse::hull::kMaxVoxel));
  auto* export_command = app.add_subcommand(
      "export", "one fused frame as a textured mesh (glTF binary, or OBJ + MTL + PNG)");
  std::string export_out;
  dataset::ExportOptions export_options;
  uint64_t export_frame = 0;
  export_command->add_option("dir", dir, "dataset folder")->required();
  export_command
      ->add_option("--out", export_out, "FILE.glb, or FILE.obj (FILE.mtl and FILE.png beside it)")
      ->required();
  export_command->add_option("--frame", export_frame,
                             "frame id (default: the first frame every camera holds)");
  export_command
      ->add_option("--atlas-size", export_options.atlas_texels,
                   "texels on a side of the atlas texture; grows (to 8192) when the hull needs")
      ->check(CLI::Range(holofuse::kMinAtlasTexels, uint32_t{8192}));
  export_command->add_option("--voxel", export_options.voxel_size, "hull voxel size in metres")
      ->check(CLI::Range(holofuse::hull::kMinVoxel, holofuse::hull::kMaxVoxel));
  HOLOFUSE_PARSE_FLAGS(app, argc, argv)
  if (export_command->parsed()) {
    if (export_command->count("--frame")) export_options.frame_id = export_frame;
    auto exported = dataset::exportTexturedFrame(dir, export_out, export_options);
    if (!exported.isOk()) {
      std::fprintf(stderr, "dataset export: %s\n", exported.status().message().c_str());
      return 2;
    }
    std::printf(
        "frame %llu: %zu vertices, %zu triangles, a %ux%u atlas (%.0f%% of its texels "
        "seen by a camera)\n",
        static_cast<unsigned long long>(exported->frame_id), exported->vertices,
        exported->triangles, exported->texels, exported->texels, 100.0 * exported->seen_share);
    for (const std::string& file : exported->files) std::printf("wrote %s\n", file.c_str());
    return 0;
  }
  if (import->parsed()) {
    const auto chosen = dataset::captureFormatFromName(format);
    if (!chosen) {
      std::fprintf(stderr, "--format '%s': unknown; valid formats: %s\n", format.c_str(),
                   dataset::captureFormatNames());
      return 2;
    }
    if (threshold >= 0) import_options.threshold = threshold;
    if (import_voxel > 0) import_options.voxel_size = import_voxel;
    import_options.rig_agreement = !no_rig_agreement;
    auto description = dataset::readCapture(source, *chosen);
    if (!description.isOk()) {
      std::fprintf(stderr, "dataset import: %s\n", description.status().message().c_str());
      return 2;
    }
    std::fprintf(stderr, "[import] %s: %zu cameras, %zu frame(s)\n", description->source.c_str(),
                 description->cameras.size(), description->frames.size());
    if (!description->frame_matching.empty())
      std::fprintf(stderr, "[import] %s\n", description->frame_matching.c_str());
    auto summary = dataset::importCapture(*description, out, import_options, printProgress);
    if (!summary.isOk()) {
      std::fprintf(stderr, "dataset import: %s (nothing was written to %s)\n",
                   summary.status().message().c_str(), out.c_str());
      return 2;
    }
    std::printf(
        "imported %zu camera(s) x %zu frame(s) into %s (%.1f MB): masks %zu from the source, %zu "
        "segmented; "
        "capture volume %s\n",
        summary->cameras, summary->frames, out.c_str(), summary->megabytes, summary->masks_given,
        summary->masks_segmented, summary->volume.c_str());
    std::printf("%s", dataset::agreementText(*summary).c_str());
    std::printf("%s", dataset::cameraHealthText(summary->camera_names, summary->health,
                                                "./holofuse dataset info " + out)
                          .c_str());
    for (const std::string& warning : summary->warnings)
      std::fprintf(stderr, "warning: %s\n", warning.c_str());
    return 0;
  }
  if (verify->parsed()) {
    auto report = dataset::verifyDataset(dir);
    if (!report.isOk()) {
      std::fprintf(stderr, "dataset verify: %s\n", report.status().message().c_str());
      return 2;
    }
    std::printf("%s", report->text.c_str());
    return static_cast<int>(report->verdict);
  }
  if (sheet.empty()) sheet = (std::filesystem::path(dir) / "contact_sheet.png").string();
  auto summary =
      dataset::describeDataset(dir, sheet, info->count("--voxel") ? voxel : 0.0, health_frames);
  if (!summary.isOk()) {
    std::fprintf(stderr, "dataset info: %s\n", summary.status().message().c_str());
    return 2;
  }
  std::printf("%s", summary->text.c_str());
  return 0;
}
