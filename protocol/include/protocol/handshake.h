// Version negotiation of SPEC.md section 4, shared by both ends.
#pragma once

#include "base/status.h"
#include "protocol/messages.h"

namespace holofuse::protocol {

// Picks the highest version inside both the peer's range and ours (1.0 to
// 1.max_minor: a server may speak less than it knows, as the older release
// it stands in for during a rolling upgrade), or says why there is none
// (naming both ranges).
StatusOr<HelloAck> negotiate(const Hello& hello, uint8_t max_minor = kVersionMinor);

// "1.N" as the newest minor a program speaks (--protocol), N at most
// kVersionMinor; an error names what is wrong.
StatusOr<uint8_t> parseProtocolVersion(const std::string& text);

// Checks a HelloAck against the range we offered.
Status checkAck(const Hello& offered, const HelloAck& ack);

}  // namespace holofuse::protocol
