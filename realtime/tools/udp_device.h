// The device of `modal-rt serve`: a haptic device in another process (or on another machine) that
// talks to the bridge over UDP. Packet layouts: realtime/README.md, "modal-rt serve".
//
// One device at a time holds the bridge (the slot). Each tick the bridge drains its socket without
// blocking and applies the session rules (realtime/README.md, "modal-rt serve"):
//   - a well-formed state from any sender takes a free slot; its sender becomes the peer;
//   - a state from another sender while the slot is held gets a refusal packet (REFUSED) and is
//     counted; an "MRTS" packet of another protocol version gets a refusal (BAD_VERSION);
//   - from the peer: HELLO restarts its session (any sequence number is accepted and becomes the
//     reference); BYE frees the slot; otherwise a sequence number 1 .. sequence_window ahead of the
//     last accepted one is fresh, anything else is stale (counted): no packet can lock a device out;
//     restart_length consecutive numbers outside the window are a counter restarted without HELLO;
//   - a HELLO from another sender takes the slot over when the peer has been silent for
//     `takeover_silence` (a driver restarted on a new port);
//   - the slot frees itself when the peer has sent no accepted state for `peer_timeout` seconds;
//   - each session change (slot taken, HELLO, takeover, counter restart, BYE, timeout) is reported
//     once by take_session_change: the loop releases every HIP (modalrt_kernel_begin_session);
//   - a tick without a fresh state from the peer is a missing tick: read_state returns false and the
//     loop applies the kernel's fail-safe rule (the last safe force held, then ramped to zero); with
//     the slot free the HIPs wait parked (read_state returns true: nobody is there to miss).
#pragma once

#include "devices.h"
#include "udp_packets.h"

#include <cstdint>
#include <memory>
#include <string>

namespace modalrt_tool
{
  struct UdpSettings
  {
    std::string   bind_address  = "127.0.0.1"; // loopback only unless asked otherwise
    std::uint16_t port          = 47000;
    std::uint32_t hips          = 1;
    double        peer_timeout  = 1.0; // [s] without an accepted state from the peer, the slot frees
    double        takeover_silence = 0.05; // [s] a HELLO from another sender takes the slot over when the
                                           // peer has been silent this long (a restarted driver)
    double        rate          = 1000.0; // [Hz] of the loop (turns peer_timeout into ticks)
    double        park[3]       = {0.0, 0.0, 1.0}; // [m] where the HIPs wait before the first state
  };

  std::unique_ptr<Device> make_udp_device(const UdpSettings &settings);
} // namespace modalrt_tool
