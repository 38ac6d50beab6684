// Version negotiation of SPEC.md section 4, shared by both ends.
#pragma once

#include "base/status.h"
#include "protocol/messages.h"

namespace holofuse::protocol {

// Picks the highest version inside both the peer's range and ours, or says
// why there is none (naming both ranges).
StatusOr<HelloAck> negotiate(const Hello& hello);

// Checks a HelloAck against the range we offered.
Status checkAck(const Hello& offered, const HelloAck& ack);

}  // namespace holofuse::protocol
