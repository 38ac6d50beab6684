#include "process_harness.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>

namespace holofuse::test {

pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = fork();
  if (pid != 0) return pid;
  std::FILE* f = std::fopen(log.c_str(), "w");
  if (f != nullptr) {
    dup2(fileno(f), STDOUT_FILENO);
    dup2(fileno(f), STDERR_FILENO);
  }
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  execv(argv[0], argv.data());
  _exit(127);
}

int waitExit(pid_t pid, int timeout_s) {
  int status = 0;
  for (int i = 0; i < timeout_s * 20; ++i) {
    if (waitpid(pid, &status, WNOHANG) == pid)
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

fs::path freshDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("holofuse_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string readFile(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string startServer(const std::string& bin_dir, const fs::path& out, int pods, pid_t* pid,
                        const std::vector<std::string>& extra) {
  const fs::path port_file = out / "port";
  std::vector<std::string> args = {
      bin_dir + "/fusion_server", "--listen",    "127.0.0.1:0",     "--pods",
      std::to_string(pods),       "--port-file", port_file.string()};
  args.insert(args.end(), extra.begin(), extra.end());
  *pid = spawn(args, out / "server.log");
  std::string port;
  for (int i = 0; i < 100 && port.empty(); ++i) {
    std::ifstream in(port_file);
    std::getline(in, port);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return port.empty() ? std::string() : "127.0.0.1:" + port;
}

}  // namespace holofuse::test
