// The datagrams of `modal-rt serve` (layouts: realtime/README.md, "modal-rt serve"): decoding a
// device's state packet (and checking its token) and encoding the bridge's command and refusal
// packets. Pure functions on byte buffers, no socket and no allocation, so the decoder can be fuzzed
// on its own (tests/fuzz/fuzz_udp_packets.cc).
#pragma once

#include <modalrt/modalrt.h>

#include <cstddef>
#include <cstdint>

namespace modalrt_tool
{
  namespace udp
  {
    // Version 3: every state packet carries the bridge's token (version 2 had none).
    constexpr std::uint16_t version         = 3;
    constexpr std::size_t   token_size      = 16; // 128 random bits
    constexpr std::size_t   token_offset    = 16;
    constexpr std::size_t   state_header    = 32; // "MRTS", u16 version, u16 hips, u32 sequence, u32 flags, token
    constexpr std::size_t   state_per_hip   = 72; // position[3], velocity[3], force[3]: f64
    constexpr std::size_t   command_header  = 24; // "MRTC", u16 version, u16 hips, u32 sequence, u32 flags, u64 tick
    constexpr std::size_t   command_per_hip = 88; // force[3], position[3], velocity[3]: f64; contact, vertex, space, flags: u32
    constexpr std::uint32_t max_hips        = 16;
    constexpr std::size_t   max_packet      = command_header + max_hips * command_per_hip;

    // Flags of a state packet (device -> bridge); any other bit makes the packet bad.
    constexpr std::uint32_t state_hello = 1u << 0; // a new session: the sequence starts again from this packet
    constexpr std::uint32_t state_bye   = 1u << 1; // the device leaves: the slot is free from now on
    constexpr std::uint32_t state_design_b = 1u << 2; // with --design-b: the hand feels design B (clear: A)
    constexpr std::uint32_t state_flags    = state_hello | state_bye | state_design_b;

    // Flags of a command packet (bridge -> device).
    constexpr std::uint32_t command_fail_safe   = 1u << 0; // an input was missing or rejected: the forces are
                                                           // the last safe ones, held or ramping to zero
    constexpr std::uint32_t command_refused     = 1u << 1; // refusal: another device holds the bridge (no HIPs)
    constexpr std::uint32_t command_bad_version = 1u << 2; // refusal: the state packet's version is not ours (no HIPs)
    constexpr std::uint32_t command_bad_token   = 1u << 3; // refusal: the state packet's token is not the bridge's

    // The number of sequence numbers ahead of the last accepted one that are accepted: a packet
    // 1 .. window ahead is fresh; anything else (the same, older, or farther ahead) is stale.
    constexpr std::uint32_t sequence_window = 1u << 16;

    // Consecutive sequence numbers outside the window (each one ahead of the one before) that make
    // the bridge take them for a counter restarted without HELLO.
    constexpr std::uint32_t restart_length = 3;

    struct HipState
    {
      double position[3], velocity[3], force[3];
    };

    // The secret a device proves it was given by the user who started the bridge.
    struct Token
    {
      unsigned char bytes[token_size];
    };

    // True if a and b hold the same token_size bytes; the time taken does not depend on where they
    // differ (a sender cannot find the token byte by byte from the bridge's answer times).
    bool same_token(const unsigned char *a, const unsigned char *b);

    // Reads exactly 2 * token_size hexadecimal digits (either case); false, token untouched, otherwise.
    bool parse_token(const char *hex, Token &token);

    // The token as 2 * token_size lowercase hexadecimal digits and a terminating zero.
    void format_token(const Token &token, char (&hex)[2 * token_size + 1]);

    enum class Verdict
    {
      good,        // well formed, the right token: sequence, flags and states are set
      bad,         // size, magic, HIP count, non-finite number or unknown flag bit
      bad_version, // "MRTS" with another version: the sender gets a refusal saying so
      bad_token    // well formed but not the bridge's token: the sender gets a refusal saying so
    };

    // Decodes a datagram of `size` bytes as the state of `hips` HIPs (1 .. max_hips): good if it is
    // well formed (exact size, magic, version, HIP count, only known flags, every number finite) and
    // carries `token`, then `sequence`, `flags` and `states[0 .. hips)` are set; otherwise all three
    // are untouched. The token is checked after the layout and before the numbers.
    Verdict decode_state(const unsigned char *packet, std::size_t size, std::uint32_t hips, const Token &token,
                         std::uint32_t &sequence, std::uint32_t &flags, HipState *states);

    // The sequence number field of a datagram (0 if it is shorter than 12 bytes), for a refusal.
    std::uint32_t sequence_of(const unsigned char *packet, std::size_t size);

    // True if `sequence` is 1 .. sequence_window ahead of `last` (the 32-bit counter may wrap).
    inline bool in_window(std::uint32_t sequence, std::uint32_t last)
    {
      const std::uint32_t ahead = sequence - last;
      return ahead >= 1 && ahead <= sequence_window;
    }

    // Writes the command of `hips` HIPs into `packet` (at least command_header + hips * command_per_hip
    // bytes) and returns its size. The header's fail-safe flag is set when any HIP's output has
    // MODALRT_HIP_FAIL_SAFE; each HIP carries its output's flags.
    std::size_t encode_command(unsigned char *packet, std::uint32_t hips, std::uint32_t sequence, std::uint64_t tick,
                               const modalrt_hip_output *outputs);

    // A refusal: a command header with no HIPs, `flags` (command_refused, command_bad_version or
    // command_bad_token), the refused packet's own sequence number and the bridge's tick count. Its
    // layout is the same in every version, so a client of an older version can read it.
    std::size_t encode_refusal(unsigned char *packet, std::uint32_t sequence, std::uint32_t flags, std::uint64_t tick);
  } // namespace udp
} // namespace modalrt_tool
