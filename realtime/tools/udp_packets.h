// The datagrams of `modal-rt serve` (layouts: realtime/README.md, "modal-rt serve"): decoding a
// device's state packet and encoding the bridge's command packet. Pure functions on byte buffers,
// no socket and no allocation, so the decoder can be fuzzed on its own (tests/fuzz/fuzz_udp_packets.cc).
#pragma once

#include <modalrt/modalrt.h>

#include <cstddef>
#include <cstdint>

namespace modalrt_tool
{
  namespace udp
  {
    constexpr std::uint16_t version          = 1;
    constexpr std::size_t   state_header     = 16; // "MRTS", u16 version, u16 hips, u32 sequence, u32 0
    constexpr std::size_t   state_per_hip    = 72; // position[3], velocity[3], force[3]: f64
    constexpr std::size_t   command_header   = 24; // "MRTC", u16 version, u16 hips, u32 sequence, u32 flags, u64 tick
    constexpr std::size_t   command_per_hip  = 88; // force[3], position[3], velocity[3]: f64; contact, vertex, space, 0: u32
    constexpr std::uint32_t flag_silent      = 1u; // no fresh state: the forces are zero
    constexpr std::uint32_t max_hips         = 16;
    constexpr std::size_t   max_packet       = command_header + max_hips * command_per_hip;

    struct HipState
    {
      double position[3], velocity[3], force[3];
    };

    // Decodes a datagram of `size` bytes as the state of `hips` HIPs (1 .. max_hips): true if it is
    // well formed (exact size, magic, version, HIP count, every number finite), then `sequence` and
    // `states[0 .. hips)` are set; false leaves both untouched.
    bool decode_state(const unsigned char *packet, std::size_t size, std::uint32_t hips, std::uint32_t &sequence,
                      HipState *states);

    // True if `sequence` comes after `last` in serial-number arithmetic (the 32-bit counter may wrap).
    inline bool is_newer(std::uint32_t sequence, std::uint32_t last) { return std::int32_t(sequence - last) > 0; }

    // Writes the command of `hips` HIPs into `packet` (at least command_header + hips * command_per_hip
    // bytes) and returns its size. A silent command carries zero forces and flag_silent.
    std::size_t encode_command(unsigned char *packet, std::uint32_t hips, std::uint32_t sequence, bool silent,
                               std::uint64_t tick, const modalrt_hip_output *outputs);
  } // namespace udp
} // namespace modalrt_tool
