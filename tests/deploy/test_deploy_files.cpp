// The deployment files of deploy/ checked against the programs they run.
// What is exercised: the Kubernetes manifests at schema level (required
// fields, selectors against labels, mounts against volumes, the Service's
// port against the server's default, the probes against the server's health
// file, Secrets mounted owner-only), every flag of every command line in
// the manifests and the systemd units against that program's --help, the
// units through systemd-analyze verify, the container definition's
// packages against the build's, and the rig files they read
// (deploy/rig.yaml, the holofuse-rig ConfigMap): parsed, each part's flags
// against its program's, each key file against the Secret mounted there.
// Not exercised here: a cluster applying the manifests, systemd starting
// the units, the image being built.
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "base/process.h"
#include "config/rig_file.h"

namespace holofuse {
namespace {

namespace fs = std::filesystem;
const fs::path kSource = HOLOFUSE_SOURCE_DIR;
const std::string kBin = HOLOFUSE_BIN_DIR;

std::string readFile(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A command's exit code and what it printed (stdout, then stderr).
std::pair<int, std::string> run(const std::vector<std::string>& args, int timeout_ms = 60000) {
  const FinishedProcess finished = runToEnd(args, timeout_ms);
  return {finished.exit_code, finished.output + finished.errors};
}

// The flags a program's --help lists: each option's line starts with its
// name (a flag named only in another's description does not count).
const std::set<std::string>& flagsOf(const std::string& program) {
  static std::map<std::string, std::set<std::string>> known;
  auto& flags = known[program];
  if (flags.empty()) {
    std::istringstream help(run({kBin + "/" + program, "--help"}).second);
    const std::regex option(R"(^\s+(?:-\w,)?(--[a-z0-9-]+))");
    std::smatch name;
    for (std::string line; std::getline(help, line);)
      if (std::regex_search(line, name, option)) flags.insert(name[1].str());
  }
  return flags;
}

std::vector<YAML::Node> manifests() {
  std::vector<YAML::Node> all;
  for (const char* file : {"rig.yaml", "server.yaml", "pods.yaml", "clients.yaml"}) {
    for (YAML::Node& doc : YAML::LoadAllFromFile((kSource / "deploy" / "k8s" / file).string()))
      all.push_back(doc);
  }
  return all;
}

YAML::Node findKind(const std::vector<YAML::Node>& all, const std::string& kind,
                    const std::string& name) {
  for (const YAML::Node& doc : all)
    if (doc["kind"].as<std::string>() == kind && doc["metadata"]["name"].as<std::string>() == name)
      return doc;
  ADD_FAILURE() << "no " << kind << " " << name << " in deploy/k8s";
  return YAML::Node();
}

// Every key of `sub` is in `labels` with the same value.
bool selects(const YAML::Node& sub, const YAML::Node& labels) {
  if (!sub.IsMap() || sub.size() == 0) return false;
  for (const auto& entry : sub) {
    const std::string key = entry.first.as<std::string>();
    if (!labels[key] || labels[key].as<std::string>() != entry.second.as<std::string>())
      return false;
  }
  return true;
}

// A container's command line, words in order (a shell script is split on
// blanks: its flags still show).
std::vector<std::string> commandLine(const YAML::Node& container) {
  std::vector<std::string> words;
  for (const char* part : {"command", "args"}) {
    if (!container[part]) continue;
    for (const auto& word : container[part]) {
      std::istringstream split(word.as<std::string>());
      for (std::string w; split >> w;) words.push_back(w);
    }
  }
  return words;
}

// Flags of `words` that program does not have.
std::vector<std::string> unknownFlags(const std::vector<std::string>& words) {
  std::string program;
  std::vector<std::string> unknown;
  for (const std::string& word : words) {
    for (const char* name : {"fusion_server", "capture_node", "render_client"})
      if (word.size() >= std::string(name).size() &&
          word.compare(word.size() - std::string(name).size(), std::string::npos, name) == 0)
        program = name;
    if (word.rfind("--", 0) != 0 || program.empty()) continue;
    if (flagsOf(program).count(word) == 0) unknown.push_back(program + " " + word);
  }
  return unknown;
}

// Where path comes from in a pod spec: "configMap NAME/KEY" or "secret
// NAME/KEY" of the volume mounted above it ("" when none is). A mounted
// volume holds its ConfigMap's or Secret's keys as files.
std::string mountedFrom(const YAML::Node& spec, const std::string& path) {
  const YAML::Node& container = spec["containers"][0];
  for (const auto& mount : container["volumeMounts"]) {
    const std::string dir = mount["mountPath"].as<std::string>() + "/";
    if (path.rfind(dir, 0) != 0) continue;
    const std::string file = path.substr(dir.size());
    for (const auto& volume : spec["volumes"]) {
      if (volume["name"].as<std::string>() != mount["name"].as<std::string>()) continue;
      if (volume["configMap"])
        return "configMap " + volume["configMap"]["name"].as<std::string>() + "/" + file;
      if (volume["secret"]) {
        // A Secret with items holds only those.
        if (volume["secret"]["items"]) {
          bool listed = false;
          for (const auto& item : volume["secret"]["items"])
            listed = listed || item["path"].as<std::string>() == file;
          if (!listed) return "";
        }
        return "secret " + volume["secret"]["secretName"].as<std::string>() + "/" + file;
      }
    }
  }
  return "";
}

std::vector<std::string> keyFiles(const std::vector<RigOption>& part) {
  std::vector<std::string> keys;
  for (const RigOption& option : part)
    if (option.name == "key-file") keys.push_back(option.values.front());
  return keys;
}

// Every flag of every part of a rig file is one its program has.
void checkRigAgainstPrograms(const RigFile& rig) {
  auto check = [](const std::string& program, const std::vector<RigOption>& part) {
    for (const RigOption& option : part)
      EXPECT_EQ(flagsOf(program).count("--" + option.name), 1u)
          << option.where << ": " << program << " has no --" << option.name;
  };
  check("fusion_server", rig.serverPart());
  for (const auto& pod : rig.pods) check("capture_node", *rig.podPart(pod.id));
  for (const auto& client : rig.clients) check("render_client", *rig.clientPart(client.id));
}

TEST(Deploy, KubernetesManifestsHoldTheirFieldsAndTheirSelectorsMatchTheirLabels) {
  const auto all = manifests();
  std::set<std::string> kinds;
  for (const YAML::Node& doc : all) {
    ASSERT_TRUE(doc["apiVersion"] && doc["kind"] && doc["metadata"]["name"]) << YAML::Dump(doc);
    const std::string kind = doc["kind"].as<std::string>();
    kinds.insert(kind);
    if (kind != "Deployment" && kind != "DaemonSet") continue;
    const YAML::Node& pod = doc["spec"]["template"];
    const std::string name = doc["metadata"]["name"].as<std::string>();
    EXPECT_TRUE(selects(doc["spec"]["selector"]["matchLabels"], pod["metadata"]["labels"]))
        << name << ": the selector does not select its own pods";
    ASSERT_TRUE(pod["spec"]["containers"] && pod["spec"]["containers"].size() > 0) << name;
    std::set<std::string> volumes;
    for (const auto& volume : pod["spec"]["volumes"]) {
      volumes.insert(volume["name"].as<std::string>());
      // Keys owner-only: the programs refuse a group-readable key file.
      if (volume["secret"]) {
        ASSERT_TRUE(volume["secret"]["defaultMode"]) << name;
        EXPECT_EQ(volume["secret"]["defaultMode"].as<int>(), 0400) << name;
      }
    }
    for (const auto& container : pod["spec"]["containers"]) {
      EXPECT_TRUE(container["name"] && container["image"]) << name;
      for (const auto& mount : container["volumeMounts"])
        EXPECT_EQ(volumes.count(mount["name"].as<std::string>()), 1u)
            << name << " mounts " << mount["name"].as<std::string>() << ", which is no volume";
      EXPECT_TRUE(unknownFlags(commandLine(container)).empty())
          << name << ": " << ::testing::PrintToString(unknownFlags(commandLine(container)));
    }
  }
  EXPECT_EQ(kinds, (std::set<std::string>{"ConfigMap", "DaemonSet", "Deployment", "Service"}));

  // The server: one replica, its Service selects it on the port the server
  // listens on by default, and both probes read the file it writes.
  const YAML::Node server = findKind(all, "Deployment", "holofuse-server");
  const YAML::Node service = findKind(all, "Service", "holofuse-server");
  const YAML::Node& server_pod = server["spec"]["template"];
  EXPECT_EQ(server["spec"]["replicas"].as<int>(), 1);
  EXPECT_TRUE(selects(service["spec"]["selector"], server_pod["metadata"]["labels"]));
  const std::string help = run({kBin + "/fusion_server", "--help"}).second;
  std::smatch port;
  ASSERT_TRUE(std::regex_search(help, port, std::regex(R"(--listen TEXT=[^:\s]+:(\d+))"))) << help;
  const YAML::Node& container = server_pod["spec"]["containers"][0];
  EXPECT_EQ(container["ports"][0]["containerPort"].as<std::string>(), port[1].str());
  EXPECT_EQ(service["spec"]["ports"][0]["port"].as<std::string>(), port[1].str());
  EXPECT_EQ(service["spec"]["ports"][0]["targetPort"].as<std::string>(),
            container["ports"][0]["name"].as<std::string>());
  const std::vector<std::string> words = commandLine(container);
  const auto health = std::find(words.begin(), words.end(), "--health-file");
  ASSERT_NE(health, words.end());
  for (const char* probe : {"readinessProbe", "livenessProbe"}) {
    const YAML::Node command = container[probe]["exec"]["command"];
    ASSERT_TRUE(command) << probe;
    EXPECT_EQ(command[1].as<std::string>(), "--check-health") << probe;
    EXPECT_EQ(command[2].as<std::string>(), *(health + 1)) << probe << " reads another file";
    EXPECT_TRUE(unknownFlags(commandLine(container[probe]["exec"])).empty()) << probe;
  }

  // The pods: pinned to capture nodes, on the node's network, reaching the
  // server by its Service's name and port.
  const YAML::Node pods = findKind(all, "DaemonSet", "holofuse-pod");
  const YAML::Node& pod_spec = pods["spec"]["template"]["spec"];
  EXPECT_TRUE(pod_spec["hostNetwork"].as<bool>());
  EXPECT_EQ(pod_spec["nodeSelector"]["holofuse.io/capture"].as<std::string>(), "true");
  // A capture node holds the pods' keys, never the server's key ring.
  for (const auto& volume : pod_spec["volumes"]) {
    if (!volume["secret"]) continue;
    EXPECT_NE(volume["secret"]["secretName"].as<std::string>(),
              server_pod["spec"]["volumes"][0]["secret"]["secretName"].as<std::string>());
  }

  // The rig file: every program reads it from the ConfigMap it mounts, it
  // sends pods and clients to the Service, and every key file it names is
  // in the Secret the reader mounts.
  const YAML::Node rig_map = findKind(all, "ConfigMap", "holofuse-rig");
  const auto rig = RigFile::parse(rig_map["data"]["rig.yaml"].as<std::string>(), "holofuse-rig");
  ASSERT_TRUE(rig.isOk()) << rig.status().message();
  EXPECT_EQ(rig->server_address, "holofuse-server:" + port[1].str());
  const YAML::Node clients = findKind(all, "Deployment", "holofuse-client");
  for (const YAML::Node& workload : {server, pods, clients}) {
    const YAML::Node& spec = workload["spec"]["template"]["spec"];
    const auto words = commandLine(spec["containers"][0]);
    const auto rig_flag = std::find(words.begin(), words.end(), "--rig");
    ASSERT_NE(rig_flag, words.end()) << workload["metadata"]["name"];
    EXPECT_EQ(mountedFrom(spec, *(rig_flag + 1)), "configMap holofuse-rig/rig.yaml");
  }
  checkRigAgainstPrograms(*rig);
  for (const std::string& key : keyFiles(rig->serverPart()))
    EXPECT_EQ(mountedFrom(server_pod["spec"], key), "secret holofuse-keys/server.keys") << key;
  for (const auto& pod : rig->pods)
    for (const std::string& key : keyFiles(*rig->podPart(pod.id)))
      EXPECT_EQ(mountedFrom(pod_spec, key),
                "secret holofuse-pod-keys/pod-" + std::to_string(pod.id) + ".key");
  for (const std::string& key : keyFiles(*rig->clientPart(0)))
    EXPECT_EQ(mountedFrom(clients["spec"]["template"]["spec"], key),
              "secret holofuse-keys/client-0.key");
  EXPECT_EQ(keyFiles(rig->serverPart()).size() + keyFiles(*rig->clientPart(0)).size(), 2u);
}

// ExecStart= and ExecStartPost= lines of a unit file, as words.
std::vector<std::string> execStart(const fs::path& unit) {
  std::istringstream in(readFile(unit));
  std::vector<std::string> words;
  for (std::string line; std::getline(in, line);) {
    const size_t equals = line.find('=');
    const std::string key = line.substr(0, equals);
    if (key != "ExecStart" && key != "ExecStartPost") continue;
    std::istringstream split(line.substr(equals + 1));
    for (std::string w; split >> w;) words.push_back(w);
  }
  return words;
}

const std::vector<std::string> kUnits = {"holofuse-server.service", "holofuse-pod@.service",
                                         "holofuse-client@.service"};

// Whether systemd-analyze verify passes every unit of `dir` and says
// nothing; it checks that each ExecStart's program exists.
void verifyUnits(const fs::path& dir) {
  const char* analyze = "/usr/bin/systemd-analyze";
  if (::access(analyze, X_OK) != 0)
    GTEST_SKIP() << "systemd-analyze (Debian's systemd) is not installed: the units were not "
                    "verified";
  for (const std::string& name : kUnits) {
    const auto [code, said] = run({analyze, "verify", (dir / name).string()});
    EXPECT_EQ(code, 0) << name << ": " << said;
    EXPECT_EQ(said, "") << name;
  }
}

// The unit templates (cmake --install writes the installed folders in:
// the tests below check what it writes).
TEST(Deploy, SystemdUnitsPassVerifyAndRunTheirProgramsFlags) {
  const fs::path units = kSource / "deploy" / "systemd";
  // The units read the rig file deploy/rig.yaml installs as.
  const auto rig = RigFile::load((kSource / "deploy" / "rig.yaml").string());
  ASSERT_TRUE(rig.isOk()) << rig.status().message();
  checkRigAgainstPrograms(*rig);
  for (const std::string& name : kUnits) {
    const auto words = execStart(units / (name + ".in"));
    ASSERT_FALSE(words.empty()) << name;
    const auto rig_flag = std::find(words.begin(), words.end(), "--rig");
    ASSERT_NE(rig_flag, words.end()) << name;
    EXPECT_EQ(*(rig_flag + 1), "/etc/holofuse/rig.yaml") << name;
    EXPECT_TRUE(unknownFlags(words).empty())
        << name << ": " << ::testing::PrintToString(unknownFlags(words));
    const std::string text = readFile(units / (name + ".in"));
    for (const char* key : {"Restart=on-failure", "LoadCredential=", "MemoryMax=", "[Install]"})
      EXPECT_NE(text.find(key), std::string::npos) << name << " has no " << key;
    EXPECT_NE(text.find("--key-file ${CREDENTIALS_DIRECTORY}/"), std::string::npos)
        << name << ": the key comes from the credentials directory";
    EXPECT_EQ(text.find("/usr/local/"), std::string::npos)
        << name << ": the installed folders are the install's to write in";
  }
}

// cmake --install into a scratch prefix: every program there answers
// --help, the loop launcher runs two frames with the programs installed
// beside it, and the units name those programs and pass verify.
TEST(Install, TheInstalledProgramsRunALoopAndTheUnitsNameThem) {
  const fs::path prefix =
      fs::temp_directory_path() / ("holofuse_install_" + std::to_string(getpid()));
  fs::remove_all(prefix);
  const auto [installed, install_said] =
      run({HOLOFUSE_CMAKE, "--install", HOLOFUSE_BUILD_DIR, "--prefix", prefix.string()}, 600000);
  ASSERT_EQ(installed, 0) << install_said;
  const std::vector<std::string> programs = {
      "fusion_server", "capture_node",   "render_client",  "holofuse_loop",   "holofuse_relay",
      "holofuse_eval", "holofuse_sweep", "holofuse_judge", "holofuse_dataset"};
  for (const std::string& program : programs) {
    const auto [code, said] = run({(prefix / "bin" / program).string(), "--help"});
    EXPECT_EQ(code, 0) << program << ": " << said;
    EXPECT_NE(said.find("--"), std::string::npos) << program << ": " << said;
  }
  EXPECT_TRUE(fs::exists(prefix / "share" / "doc" / "holofuse" / "runbook.md"));
  EXPECT_TRUE(fs::exists(prefix / "share" / "doc" / "holofuse" / "examples" / "rig.yaml"));

  const fs::path units = prefix / "lib" / "systemd" / "system";
  for (const std::string& name : kUnits) {
    const auto words = execStart(units / name);
    ASSERT_FALSE(words.empty()) << name;
    EXPECT_EQ(words[0].rfind((prefix / "bin").string() + "/", 0), 0u) << name << ": " << words[0];
    EXPECT_NE(readFile(units / name).find("file:" + (prefix / "share/doc/holofuse").string()),
              std::string::npos)
        << name;
  }

  const fs::path out = prefix / "loop";
  const auto [looped, loop_said] =
      run({(prefix / "bin" / "holofuse_loop").string(), "--frames", "2", "--pods", "2", "--size",
           "64x48", "--out", out.string()},
          600000);
  ASSERT_EQ(looped, 0) << loop_said;
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_000000.png"));
  EXPECT_TRUE(fs::exists(out / "frames" / "frame_000001.png"));
  // The launcher started the installed programs, not the build's.
  EXPECT_NE(loop_said.find("[loop] programs from " + (prefix / "bin").string() + "\n"),
            std::string::npos)
      << loop_said;
  verifyUnits(units);
  if (!HasFailure()) fs::remove_all(prefix);
}

// The Debian package CPack makes: the programs in /usr/bin, the units
// naming them, and its dependencies read off the programs' libraries.
TEST(Install, TheDebianPackageHoldsTheProgramsTheUnitsAndTheirLibraries) {
  const fs::path out = fs::temp_directory_path() / ("holofuse_package_" + std::to_string(getpid()));
  fs::remove_all(out);
  const auto [packed, pack_said] =
      run({HOLOFUSE_CPACK, "--config", std::string(HOLOFUSE_BUILD_DIR) + "/CPackConfig.cmake", "-B",
           out.string()},
          600000);
  ASSERT_EQ(packed, 0) << pack_said;
  const std::string dpkg_deb = "/usr/bin/dpkg-deb";
  if (::access(dpkg_deb.c_str(), X_OK) != 0)
    GTEST_SKIP() << "dpkg-deb is not installed: the package was made but not read";
  fs::path deb;
  for (const auto& entry : fs::directory_iterator(out))
    if (entry.path().extension() == ".deb") deb = entry.path();
  ASSERT_FALSE(deb.empty()) << pack_said;
  const auto [info_code, info] = run({dpkg_deb, "--field", deb.string(), "Package", "Depends"});
  ASSERT_EQ(info_code, 0) << info;
  EXPECT_NE(info.find("Package: holofuse"), std::string::npos) << info;
  for (const char* library : {"libvulkan1", "libopencv-core", "libdraco", "liblz4-1", "libtbb",
                              "libopenimageio", "libavcodec", "libssl3"})
    EXPECT_NE(info.find(library), std::string::npos) << "Depends lacks " << library << ": " << info;
  EXPECT_EQ(info.find("-dev"), std::string::npos) << "a development package: " << info;
  const fs::path tree = out / "tree";
  const auto [unpacked, unpack_said] = run({dpkg_deb, "--extract", deb.string(), tree.string()});
  ASSERT_EQ(unpacked, 0) << unpack_said;
  for (const char* program : {"fusion_server", "capture_node", "render_client", "holofuse_loop"})
    EXPECT_TRUE(fs::exists(tree / "usr" / "bin" / program)) << program;
  const auto words = execStart(tree / "usr/lib/systemd/system/holofuse-server.service");
  ASSERT_FALSE(words.empty());
  EXPECT_EQ(words[0], "/usr/bin/fusion_server");
  if (!HasFailure()) fs::remove_all(out);
}

// The image builds on Debian 12 with every package the build uses, and
// ships the installed programs on the slim image, as a user of its own.
TEST(Deploy, TheContainerImageBuildsOnDebian12AndShipsTheInstalledProgramsSlim) {
  const std::string file = readFile(kSource / "deploy" / "container" / "Containerfile");
  const size_t runtime_from = file.find("\nFROM debian:12-slim\n");
  ASSERT_NE(runtime_from, std::string::npos) << "no slim runtime stage";
  ASSERT_EQ(file.find("\nFROM ", runtime_from + 1), std::string::npos) << "the slim stage is last";
  const std::string containerfile = file.substr(0, runtime_from);  // the build stage
  const std::string runtime = file.substr(runtime_from);
  EXPECT_NE(containerfile.find("FROM debian:12 AS build"), std::string::npos);
  // The runtime stage installs the package the build stage made, and
  // neither sources nor tools.
  EXPECT_NE(runtime.find("COPY --from=build /holofuse.deb"), std::string::npos) << runtime;
  EXPECT_NE(containerfile.find("cpack -G DEB"), std::string::npos);
  for (const char* absent : {"-dev ", "build-essential", "cmake", "COPY . "})
    EXPECT_EQ(runtime.find(absent), std::string::npos) << "the slim stage has " << absent;
  const std::regex user(R"(\nUSER ([a-z_][a-z0-9_-]*)\n)");
  std::smatch named;
  ASSERT_TRUE(std::regex_search(runtime, named, user)) << "the image runs as root";
  EXPECT_NE(named[1].str(), "root");
  EXPECT_NE(runtime.find("CMD [\"/usr/bin/fusion_server\""), std::string::npos)
      << "the command is the installed program";
  // The context sent to the builder leaves the build folders out.
  const std::string ignored = readFile(kSource / ".containerignore");
  for (const char* line : {"\nbuild\n", "\nbuild-*\n", "\n.git\n"})
    EXPECT_NE(("\n" + ignored).find(line), std::string::npos) << ".containerignore lacks " << line;
  // The manifests run the installed programs; those that mount keys run
  // as root (a Secret's owner), the others as the image's user.
  for (const YAML::Node& doc : manifests()) {
    if (!doc["spec"] || !doc["spec"]["template"]) continue;
    for (const auto& container : doc["spec"]["template"]["spec"]["containers"]) {
      const std::string program = container["command"][0].as<std::string>();
      EXPECT_EQ(program.rfind("/usr/bin/", 0), 0u) << program;
      bool keys = false;
      for (const auto& mount : container["volumeMounts"])
        keys |= mount["mountPath"].as<std::string>().find("keys") != std::string::npos;
      if (keys) {
        EXPECT_EQ(container["securityContext"]["runAsUser"].as<int>(-1), 0)
            << program << " reads a root-owned key";
      }
    }
  }
  // ./holofuse's list of what the programs need (the tests' and the other
  // commands' extra packages are lists of their own, which a demo and the
  // image never install).
  const std::string script = readFile(kSource / "holofuse");
  const size_t from = script.find("packages=(");
  ASSERT_NE(from, std::string::npos);
  // The list ends at the first ')' outside a comment.
  std::string list;
  std::istringstream rest(script.substr(from + 10));
  for (std::string line; std::getline(rest, line);) {
    const std::string code = line.substr(0, line.find('#'));
    list += code.substr(0, code.find(')')) + "\n";
    if (code.find(')') != std::string::npos) break;
  }
  const std::set<std::string> test_only = {"clang-format",
                                           "clang",
                                           "libclang-rt-14-dev",
                                           "assimp-utils",
                                           "chromium",
                                           "ffmpeg",
                                           "gir1.2-gst-rtsp-server-1.0",
                                           "gstreamer1.0-plugins-good",
                                           "python3-gi",
                                           "xvfb",
                                           "xdotool",
                                           "imagemagick"};
  std::istringstream lines(list);
  size_t checked = 0;
  for (std::string line; std::getline(lines, line);) {
    std::istringstream words(line);
    for (std::string package; words >> package;) {
      EXPECT_EQ(test_only.count(package), 0u) << package << " is for the tests only";
      ++checked;
      EXPECT_NE(containerfile.find(" " + package + " "), std::string::npos)
          << "the build stage lacks " << package;
    }
  }
  EXPECT_GT(checked, 20u) << list;
  EXPECT_NE(runtime.find("EXPOSE 7300"), std::string::npos);
}

}  // namespace
}  // namespace holofuse
