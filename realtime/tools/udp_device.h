// The device of `modal-rt serve`: a haptic device in another process (or on another machine) that
// talks to the bridge over UDP. Packet layouts: realtime/README.md, "modal-rt serve".
//
// Each tick the bridge drains its socket without blocking. The first well-formed state packet
// chooses the peer (its address and port); packets from any other sender are ignored and counted.
// A packet whose sequence number is not newer than the last accepted one (serial-number arithmetic,
// so the 32-bit counter may wrap) is stale: ignored and counted. Malformed packets (size, magic,
// version, HIP count, non-finite numbers) are ignored and counted. When no fresh state has arrived
// during the last `silence_ticks` ticks the device is silent: the HIPs hold their last position at
// zero velocity with zero user force, and the command sent back carries zero force and the SILENT
// flag, from that very tick on.
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
    std::uint32_t silence_ticks = 1;
    double        park[3]       = {0.0, 0.0, 1.0}; // [m] where the HIPs wait before the first state
  };

  std::unique_ptr<Device> make_udp_device(const UdpSettings &settings);
} // namespace modalrt_tool
