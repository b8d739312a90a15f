// The device of `modal-rt serve`: a haptic device in another process (or on another machine) that
// talks to the bridge over UDP. Packet layouts: realtime/README.md, "modal-rt serve".
//
// One device at a time holds the bridge (the slot), and only a device given the bridge's token:
// the rules (the slot, the token, HELLO, takeover, time-out, sequence window, fail-safe) are written
// once, in realtime/README.md, "Rules of the bridge"; this file implements them while draining the
// socket each tick without blocking. Each session change is reported once by take_session_change:
// the loop releases every HIP (modalrt_kernel_begin_session). A tick without a fresh state from the
// peer is a missing tick (read_state returns false, the kernel's fail-safe rule); with the slot free
// the HIPs wait parked (read_state returns true: nobody is there to miss).
//
// The token: --token HEX, or 128 random bits drawn at open() and written (mode 0600, created
// atomically) to token_file, which close() removes.
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
    bool          token_given   = false; // --token: `token` is set; otherwise open() draws one
    udp::Token    token{};
    std::string   token_file;            // where open() writes the token ("": the default path, or none
                                         // when the token was given)
    double        rate          = 1000.0; // [Hz] of the loop (turns peer_timeout into ticks)
    double        park[3]       = {0.0, 0.0, 1.0}; // [m] where the HIPs wait before the first state
  };

  // The default token file of a bridge on `port`: $XDG_RUNTIME_DIR/modal-rt/serve-PORT.token, or
  // /tmp/modal-rt-UID/serve-PORT.token without XDG_RUNTIME_DIR.
  std::string default_token_file(std::uint16_t port);

  std::unique_ptr<Device> make_udp_device(const UdpSettings &settings);
} // namespace modalrt_tool
