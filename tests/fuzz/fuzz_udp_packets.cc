// libFuzzer harness of the state-packet decoder of `modal-rt serve` (realtime/tools/udp_packets.cc),
// built by tests/fuzz/CMakeLists.txt with clang -fsanitize=fuzzer,address,undefined and run by
// scripts/test-kernel-checks. Every datagram a peer sends reaches udp::decode_state, so it must never
// read outside the datagram, and it must accept exactly the packets the layout of realtime/README.md
// allows: the verdict is compared with an oracle written here from that layout, and an accepted
// packet's numbers with its bytes.
//
// Each input is one datagram, decoded as the bridge would for the HIP count it declares (when that is
// a count the bridge can be started with) and for one HIP, the default.
#include "udp_packets.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace
{
  namespace udp = modalrt_tool::udp;

  // A broken promise of the decoder is a finding: report it and abort, so libFuzzer keeps the input.
  void expect(bool condition, const char *what)
  {
    if (!condition)
      {
        std::fprintf(stderr, "fuzz_udp_packets: broken expectation: %s\n", what);
        std::abort();
      }
  }

  template <typename T> T get(const std::uint8_t *data, std::size_t offset)
  {
    T value;
    std::memcpy(&value, data + offset, sizeof value);
    return value;
  }

  // The token the harness's bridge holds: the seed corpus's packets carry it (16 bytes 0x5A).
  udp::Token harness_token()
  {
    udp::Token t;
    std::memset(t.bytes, 0x5A, sizeof t.bytes);
    return t;
  }

  // The layout, read independently of the decoder: "MRTS", u16 version 3, u16 HIP count, u32
  // sequence, u32 flags (bits 0 HELLO, 1 BYE and 2 DESIGN_B only), the 16-byte token, then 9
  // finite f64 per HIP.
  // An "MRTS" packet of at least 8 bytes with another version is told apart (the sender gets a
  // refusal), and so is a well-formed packet with another token (checked before the numbers).
  udp::Verdict documented_verdict(const std::uint8_t *data, std::size_t size, std::uint32_t hips)
  {
    if (size >= 8 && std::memcmp(data, "MRTS", 4) == 0 && get<std::uint16_t>(data, 4) != 3)
      return udp::Verdict::bad_version;
    if (size != 32 + 72 * std::size_t(hips) || std::memcmp(data, "MRTS", 4) != 0 || get<std::uint16_t>(data, 6) != hips ||
        get<std::uint32_t>(data, 12) > 7u)
      return udp::Verdict::bad;
    for (std::size_t k = 16; k < 32; ++k)
      if (data[k] != 0x5A)
        return udp::Verdict::bad_token;
    for (std::size_t k = 0; k < 9 * std::size_t(hips); ++k)
      if (!std::isfinite(get<double>(data, 32 + 8 * k)))
        return udp::Verdict::bad;
    return udp::Verdict::good;
  }

  void decode_as(const std::uint8_t *data, std::size_t size, std::uint32_t hips)
  {
    // Sentinels: a refused packet must leave the outputs as they were.
    udp::HipState states[udp::max_hips];
    std::memset(states, 0xA5, sizeof states);
    std::uint32_t      sequence = 0xDEADBEEF, flags = 0xDEADBEEF;
    const udp::Verdict verdict  = udp::decode_state(data, size, hips, harness_token(), sequence, flags, states);
    expect(verdict == documented_verdict(data, size, hips), "the verdict differs from the documented layout");
    if (verdict != udp::Verdict::good)
      {
        udp::HipState untouched[udp::max_hips];
        std::memset(untouched, 0xA5, sizeof untouched);
        expect(sequence == 0xDEADBEEF && flags == 0xDEADBEEF && std::memcmp(states, untouched, sizeof states) == 0,
               "a refused packet changed the outputs");
        return;
      }
    expect(sequence == get<std::uint32_t>(data, 8), "the sequence number is not the packet's");
    expect(flags == get<std::uint32_t>(data, 12), "the flags are not the packet's");
    for (std::uint32_t h = 0; h < hips; ++h)
      for (int k = 0; k < 3; ++k)
        {
          const std::size_t at = 32 + 72 * std::size_t(h) + 8 * std::size_t(k);
          expect(states[h].position[k] == get<double>(data, at) && states[h].velocity[k] == get<double>(data, at + 24) &&
                   states[h].force[k] == get<double>(data, at + 48),
                 "a decoded number is not the packet's");
        }
    // The sequence window: a number is never fresh after itself, of two numbers at most one is fresh
    // after the other, and exactly 1 .. 65536 ahead is fresh (wrapping).
    const std::uint32_t other = get<std::uint32_t>(data, 32) ^ get<std::uint32_t>(data, 36);
    expect(!udp::in_window(sequence, sequence), "a sequence number is fresh after itself");
    expect(!(udp::in_window(sequence, other) && udp::in_window(other, sequence)), "two sequence numbers are each fresh");
    const std::uint32_t ahead = other - sequence;
    expect(udp::in_window(other, sequence) == (ahead >= 1 && ahead <= 65536u), "the window is not 1 .. 65536 ahead");
  }
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t *data, std::size_t size)
{
  // libFuzzer's buffer is exactly `size` bytes: AddressSanitizer sees any read beyond the datagram.
  decode_as(data, size, 1);
  if (size >= 8)
    {
      const std::uint32_t declared = get<std::uint16_t>(data, 6);
      if (declared > 1 && declared <= udp::max_hips)
        decode_as(data, size, declared);
    }
  return 0;
}
