// `./holofuse dataset export`: a fused frame written as glTF binary and as
// OBJ + MTL + PNG, read back by an independent reader (Debian's assimp).
#include <fstream>
#include <regex>
#include <sstream>

#include "base/process.h"
#include "dataset/capture_formats.h"
#include "dataset/import.h"
#include "dataset/textured_export.h"
#include "image/image_io.h"
#include "import_fixture.h"

namespace holofuse::dataset {
namespace {

class ExportTest : public SyntheticCapture {
 protected:
  // The synthetic capture imported as a dataset.
  fs::path importedDataset() {
    const fs::path src = root_ / "src";
    writeImages(src / "images", ".png");
    writeMasks(src / "masks", ".png", false);
    std::ofstream(src / "capture.json") << holofuseJson(".png", true).dump(2);
    auto capture = readCapture(src.string(), CaptureFormat::kHolofuse);
    EXPECT_TRUE(capture.isOk()) << capture.status().toString();
    const fs::path out = root_ / "dataset";
    if (capture.isOk()) {
      auto summary = importCapture(*capture, out.string(), ImportOptions{});
      EXPECT_TRUE(summary.isOk()) << summary.status().toString();
    }
    return out;
  }

  // What `assimp ARGS` prints; skips the test where assimp is missing.
  std::string assimp(const std::vector<std::string>& args) {
    const fs::path log = root_ / "assimp.log";
    std::vector<std::string> command = {"/usr/bin/assimp"};
    command.insert(command.end(), args.begin(), args.end());
    SpawnOptions options;
    options.log_path = log.string();
    auto pid = spawnProcess(command, options);
    if (!pid.isOk()) return "";
    const auto code = waitProcess(*pid, 120000);
    EXPECT_EQ(code, 0) << "assimp failed";
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  }

  static size_t countAfter(const std::string& text, const std::string& label) {
    std::smatch match;
    if (!std::regex_search(text, match, std::regex(label + R"(\s*:?\s*(\d+))"))) return 0;
    return std::stoul(match[1]);
  }
};

TEST_F(ExportTest, AFusedFrameOpensInAnotherReaderWithItsAtlas) {
  if (!fs::exists("/usr/bin/assimp"))
    GTEST_SKIP() << "assimp (Debian's assimp-utils) is not installed: ./holofuse deps installs it";
  const fs::path dataset = importedDataset();
  ExportOptions options;
  options.atlas_texels = 512;
  auto glb = exportTexturedFrame(dataset.string(), (root_ / "frame.glb").string(), options);
  ASSERT_TRUE(glb.isOk()) << glb.status().toString();
  EXPECT_GT(glb->triangles, 500u);
  // Measured 0.74: four cameras at one height miss the top of the head, the
  // soles and the hull's phantom wedges between the legs.
  EXPECT_GT(glb->seen_share, 0.6) << "four cameras round a figure see most of it";
  auto obj = exportTexturedFrame(dataset.string(), (root_ / "frame.obj").string(), options);
  ASSERT_TRUE(obj.isOk()) << obj.status().toString();
  ASSERT_EQ(obj->files.size(), 3u);
  EXPECT_EQ(obj->triangles, glb->triangles) << "the same frame fuses the same way";

  // glTF: a vertex per corner (an atlas splits every vertex), a face per
  // triangle, one embedded texture.
  const std::string glb_info = assimp({"info", (root_ / "frame.glb").string()});
  EXPECT_EQ(countAfter(glb_info, "Vertices"), 3 * glb->triangles) << glb_info;
  EXPECT_EQ(countAfter(glb_info, "Faces"), glb->triangles) << glb_info;
  // OBJ: the vertices stay shared in the file; assimp gives each corner
  // its own, as it does for any OBJ with texture coordinates.
  const std::string obj_info = assimp({"info", (root_ / "frame.obj").string()});
  EXPECT_EQ(countAfter(obj_info, "Faces"), obj->triangles) << obj_info;

  // Texture coordinates as the other reader sees them: every one in [0,1].
  assimp({"export", (root_ / "frame.glb").string(), (root_ / "reread.obj").string()});
  std::ifstream reread(root_ / "reread.obj");
  size_t uvs = 0;
  for (std::string line; std::getline(reread, line);) {
    if (line.rfind("vt ", 0) != 0) continue;
    std::istringstream in(line.substr(3));
    double u = -1, v = -1;
    in >> u >> v;
    EXPECT_TRUE(u >= 0 && u <= 1 && v >= 0 && v <= 1) << line;
    ++uvs;
  }
  EXPECT_GT(uvs, glb->triangles) << "assimp wrote the glTF's texture coordinates back out";

  // The texture: the atlas's size, beside the OBJ and inside the glTF.
  auto png_size = readImageSize((root_ / "frame.png").string());
  ASSERT_TRUE(png_size.isOk()) << png_size.status().toString();
  EXPECT_EQ(png_size->first, obj->texels);
  EXPECT_EQ(png_size->second, obj->texels);
  EXPECT_GE(obj->texels, 512u);
  assimp({"extract", (root_ / "frame.glb").string(), (root_ / "embedded.png").string()});
  std::vector<fs::path> extracted;
  for (const auto& entry : fs::directory_iterator(root_))
    if (entry.path().filename().string().rfind("embedded", 0) == 0)
      extracted.push_back(entry.path());
  ASSERT_EQ(extracted.size(), 1u) << "assimp found one embedded texture";
  auto embedded = readImageSize(extracted.front().string());
  ASSERT_TRUE(embedded.isOk()) << embedded.status().toString();
  EXPECT_EQ(embedded->first, glb->texels);
}

TEST_F(ExportTest, AnUnknownExtensionOrFrameIsRefusedByName) {
  const fs::path dataset = importedDataset();
  auto ply = exportTexturedFrame(dataset.string(), (root_ / "frame.ply").string());
  ASSERT_FALSE(ply.isOk());
  EXPECT_NE(ply.status().message().find("'.ply'"), std::string::npos) << ply.status().message();
  ExportOptions options;
  options.frame_id = 999;
  auto missing = exportTexturedFrame(dataset.string(), (root_ / "frame.glb").string(), options);
  ASSERT_FALSE(missing.isOk());
  EXPECT_NE(missing.status().message().find("lacks frame 999"), std::string::npos)
      << missing.status().message();
  EXPECT_FALSE(fs::exists(root_ / "frame.glb")) << "nothing written for a refused export";
}

}  // namespace
}  // namespace holofuse::dataset
