// Pre-shared keys and the HMAC-SHA256 challenge of SPEC.md section 4: a
// pod or client proves it holds the key of the identity it claims (its
// role and id) before the server parses anything but its Hello, and the
// server proves it holds that key too. The MACs cover both nonces, the
// agreed version, the role and the id, so an answer recorded on one
// connection is worth nothing on another. Payloads are not encrypted.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "base/status.h"
#include "protocol/messages.h"

namespace holofuse::protocol {

using AuthBytes = std::array<uint8_t, kAuthBytes>;

// The keys of a key file: one per line, "<identity> <hex key>" or just
// "<hex key>" (identity "*"); '#' starts a comment. Identities: "pod:3",
// "client:0", "pod:*", "client:*", "*". A key is at least 32 bytes (64
// hex digits). A file that its group or others may read is refused, as
// ssh refuses a private key: the key is the rig's only secret.
class KeyRing {
 public:
  static StatusOr<KeyRing> load(const std::string& path);
  // A fresh random key (32 bytes from the system's CSPRNG) for identity,
  // written with mode 0600; refuses to overwrite an existing file.
  static Status writeNew(const std::string& path, const std::string& identity = "*");
  // Per-identity keys for a rig, in dir (created when missing): server.keys
  // (every identity: the server's ring), pod-<i>.key for pods 0..pods-1
  // and client-<j>.key for each client id, each holding its own identity's
  // key only, mode 0600. Nothing is written when any of them exists.
  // Returns the files, the ring first.
  static StatusOr<std::vector<std::string>> writeRig(const std::string& dir, uint32_t pods,
                                                     const std::vector<uint32_t>& client_ids);

  // The key that authenticates (role, id): its own entry, else its role's
  // "role:*", else "*"; nullptr when the file has none. A pod with its own
  // entry is authenticated by that key only.
  const std::vector<uint8_t>* keyFor(Role role, uint32_t id) const;
  const std::string& path() const { return path_; }

 private:
  struct Entry {
    std::string identity;
    std::vector<uint8_t> key;
  };
  std::string path_;
  std::vector<Entry> entries_;
};

// The key file a program uses: its --key-file flag, else
// $HOLOFUSE_KEY_FILE, else none (empty).
std::string keyFilePath(const std::string& flag);

// The key a pod or client authenticates with: from keyFilePath(flag), the
// entry for (role, id); empty when there is no key file (the peer can join
// only a server without authentication). An error names the file.
StatusOr<std::vector<uint8_t>> loadPeerKey(const std::string& flag, Role role, uint32_t id);

// Random bytes for a challenge, and a random Hello nonce, from the CSPRNG.
AuthBytes randomAuthBytes();
uint64_t randomNonce();

// The MAC of one step (kResponse: the peer's; kProof: the server's) over
// "holofuse-auth-1", the step, the Hello's role, id and nonce, the agreed
// major and minor and the server's challenge.
AuthBytes authMac(const std::vector<uint8_t>& key, AuthStep step, const Hello& hello, uint8_t major,
                  uint8_t minor, const AuthBytes& challenge);
// Constant-time comparison (CRYPTO_memcmp), so timing tells nothing.
bool sameMac(const AuthBytes& a, const AuthBytes& b);

// "pod 3", "client 0": how logs and refusals name an identity.
std::string identityName(Role role, uint32_t id);

}  // namespace holofuse::protocol
