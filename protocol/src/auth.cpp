#include "protocol/auth.h"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace holofuse::protocol {
namespace {

constexpr size_t kMinKeyBytes = 32;

std::string roleName(Role role) { return role == Role::kPod ? "pod" : "client"; }

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool validIdentity(const std::string& identity) {
  if (identity == "*") return true;
  const size_t colon = identity.find(':');
  if (colon == std::string::npos) return false;
  const std::string role = identity.substr(0, colon), id = identity.substr(colon + 1);
  if (role != "pod" && role != "client") return false;
  if (id == "*") return true;
  return !id.empty() && id.size() <= 9 && id.find_first_not_of("0123456789") == std::string::npos;
}

}  // namespace

StatusOr<KeyRing> KeyRing::load(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    return Status(StatusCode::kIoError, path + ": key file is missing");
  if (!S_ISREG(st.st_mode)) return Status(StatusCode::kIoError, path + ": not a regular file");
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    return Status(StatusCode::kUnauthenticated,
                  path + ": key file is readable by others (mode " + mode + "); chmod 600 " + path);
  }
  std::ifstream in(path);
  if (!in) return Status(StatusCode::kIoError, path + ": cannot read the key file");
  KeyRing ring;
  ring.path_ = path;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (const size_t hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::istringstream fields(line);
    std::vector<std::string> words;
    for (std::string w; fields >> w;) words.push_back(w);
    if (words.empty()) continue;
    const std::string where = path + ":" + std::to_string(number);
    if (words.size() > 2)
      return Status(StatusCode::kMalformed, where + ": expected \"<identity> <hex key>\"");
    Entry entry;
    entry.identity = words.size() == 2 ? words[0] : "*";
    if (!validIdentity(entry.identity)) {
      return Status(StatusCode::kMalformed,
                    where + ": identity \"" + entry.identity +
                        "\" is not pod:<id>, client:<id>, pod:*, client:* or *");
    }
    const std::string& hex = words.back();
    if (hex.size() % 2 != 0)
      return Status(StatusCode::kMalformed, where + ": the key has an odd number of hex digits");
    for (size_t i = 0; i < hex.size(); i += 2) {
      const int hi = hexDigit(hex[i]), lo = hexDigit(hex[i + 1]);
      if (hi < 0 || lo < 0)
        return Status(StatusCode::kMalformed, where + ": the key is not hexadecimal");
      entry.key.push_back(static_cast<uint8_t>(hi * 16 + lo));
    }
    if (entry.key.size() < kMinKeyBytes) {
      return Status(StatusCode::kMalformed, where + ": a key of " +
                                                std::to_string(entry.key.size()) +
                                                " bytes; at least 32 are needed");
    }
    for (const Entry& e : ring.entries_) {
      if (e.identity == entry.identity)
        return Status(StatusCode::kMalformed, where + ": identity " + e.identity + " twice");
    }
    ring.entries_.push_back(std::move(entry));
  }
  if (ring.entries_.empty()) return Status(StatusCode::kMalformed, path + ": holds no key");
  return ring;
}

namespace {

// "<identity> <64 hex digits>" for a fresh key: 32 bytes from the CSPRNG.
StatusOr<std::string> newKeyLine(const std::string& identity) {
  std::array<uint8_t, 32> key{};
  if (RAND_bytes(key.data(), static_cast<int>(key.size())) != 1)
    return Status(StatusCode::kIoError, "the system's random generator failed");
  std::string line = identity + " ";
  for (uint8_t b : key) {
    static const char* digits = "0123456789abcdef";
    line += digits[b >> 4];
    line += digits[b & 15];
  }
  return line + "\n";
}

// Writes text to a new file of mode 0600; never overwrites one.
Status writeSecretFile(const std::string& path, const std::string& text) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    return Status(StatusCode::kIoError,
                  path + (errno == EEXIST ? ": exists; not overwritten" : ": cannot create"));
  }
  const bool written = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ::close(fd);
  if (!written) {
    ::unlink(path.c_str());
    return Status(StatusCode::kIoError, path + ": could not write the key");
  }
  return Status::ok();
}

constexpr const char* kKeyFileHeader = "# holofuse key: keep it secret (mode 0600)\n";

}  // namespace

Status KeyRing::writeNew(const std::string& path, const std::string& identity) {
  if (!validIdentity(identity))
    return Status(StatusCode::kMalformed, "identity \"" + identity + "\" is not valid");
  auto line = newKeyLine(identity);
  if (!line.isOk()) return Status(line.status().code(), path + ": " + line.status().message());
  return writeSecretFile(path, kKeyFileHeader + *line);
}

StatusOr<std::vector<std::string>> KeyRing::writeRig(const std::string& dir, uint32_t pods,
                                                     const std::vector<uint32_t>& client_ids) {
  namespace fs = std::filesystem;
  std::vector<std::pair<std::string, std::string>> files;  // path, identity
  for (uint32_t i = 0; i < pods; ++i)
    files.emplace_back((fs::path(dir) / ("pod-" + std::to_string(i) + ".key")).string(),
                       "pod:" + std::to_string(i));
  for (const uint32_t i : client_ids)
    files.emplace_back((fs::path(dir) / ("client-" + std::to_string(i) + ".key")).string(),
                       "client:" + std::to_string(i));
  const std::string ring_path = (fs::path(dir) / "server.keys").string();
  // Nothing is written over, and nothing half: every name is checked first.
  std::error_code error;
  std::vector<std::string> paths = {ring_path};
  for (const auto& file : files) paths.push_back(file.first);
  for (const std::string& path : paths) {
    if (fs::exists(path, error))
      return Status(StatusCode::kIoError, path + ": exists; not overwritten");
  }
  fs::create_directories(dir, error);
  if (error) return Status(StatusCode::kIoError, dir + ": cannot create (" + error.message() + ")");
  std::string ring =
      kKeyFileHeader + std::string("# the server's ring: every identity of the rig\n");
  std::vector<std::string> written;
  for (const auto& [path, identity] : files) {
    auto line = newKeyLine(identity);
    if (!line.isOk()) return line.status();
    ring += *line;
    HOLOFUSE_RETURN_IF_ERROR(writeSecretFile(path, kKeyFileHeader + *line));
    written.push_back(path);
  }
  HOLOFUSE_RETURN_IF_ERROR(writeSecretFile(ring_path, ring));
  written.insert(written.begin(), ring_path);
  return written;
}

const std::vector<uint8_t>* KeyRing::keyFor(Role role, uint32_t id) const {
  for (const std::string& wanted :
       {roleName(role) + ":" + std::to_string(id), roleName(role) + ":*", std::string("*")}) {
    for (const Entry& e : entries_) {
      if (e.identity == wanted) return &e.key;
    }
  }
  return nullptr;
}

std::string keyFilePath(const std::string& flag) {
  if (!flag.empty()) return flag;
  const char* env = std::getenv("HOLOFUSE_KEY_FILE");
  return env != nullptr ? env : "";
}

StatusOr<std::vector<uint8_t>> loadPeerKey(const std::string& flag, Role role, uint32_t id) {
  const std::string path = keyFilePath(flag);
  if (path.empty()) return std::vector<uint8_t>{};
  auto ring = KeyRing::load(path);
  if (!ring.isOk()) return ring.status();
  const std::vector<uint8_t>* key = ring->keyFor(role, id);
  if (key == nullptr) {
    return Status(StatusCode::kUnauthenticated,
                  path + ": no key for " + identityName(role, id) + " (nor for " +
                      (role == Role::kPod ? "pod:*" : "client:*") + " or *)");
  }
  return *key;
}

AuthBytes randomAuthBytes() {
  AuthBytes out{};
  if (RAND_bytes(out.data(), static_cast<int>(out.size())) != 1) {
    // No entropy is a broken system, not a condition to serve through.
    std::fprintf(stderr, "holofuse: the system's random generator failed\n");
    std::abort();
  }
  return out;
}

uint64_t randomNonce() {
  const AuthBytes bytes = randomAuthBytes();
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | bytes[static_cast<size_t>(i)];
  return v;
}

AuthBytes authMac(const std::vector<uint8_t>& key, AuthStep step, const Hello& hello, uint8_t major,
                  uint8_t minor, const AuthBytes& challenge) {
  Bytes transcript;
  WireWriter w(transcript);
  const std::string label = "holofuse-auth-1";
  w.raw(std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(label.data()), label.size()));
  w.u8(static_cast<uint8_t>(step));
  w.u8(static_cast<uint8_t>(hello.role));
  w.u32(hello.id);
  w.u64(hello.nonce);
  w.u8(major);
  w.u8(minor);
  w.raw(challenge);
  AuthBytes mac{};
  unsigned int length = 0;
  HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), transcript.data(), transcript.size(),
       mac.data(), &length);
  return mac;
}

bool sameMac(const AuthBytes& a, const AuthBytes& b) {
  return CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

std::string identityName(Role role, uint32_t id) {
  return roleName(role) + " " + std::to_string(id);
}

}  // namespace holofuse::protocol
