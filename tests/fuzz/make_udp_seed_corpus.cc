// Writes the seed corpus of fuzz_udp_packets (tests/fuzz/corpus/udp/, committed): state packets as a
// device driver sends them (1, 2 and 16 HIPs, a wrapping sequence number, HELLO, BYE) and one variant
// per check of the decoder (size, magic, version 1 and 3, HIP count, an unknown flag, a NaN and an
// infinity). Packets are encoded here
// from the layout of realtime/README.md, not with the tool's code.
//
//   make_udp_seed_corpus DIR     (run again only when the packet layout changes)
#include "seed_file.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace
{
  using Bytes = std::vector<unsigned char>;
  using seed::save;

  template <typename T> void put(Bytes &bytes, std::size_t offset, T value)
  {
    std::memcpy(bytes.data() + offset, &value, sizeof value);
  }

  // "MRTS", u16 version 3, u16 HIP count, u32 sequence, u32 flags, the token (16 bytes 0x5A, the
  // harness's), then per HIP position, velocity and force (f64), each HIP a little apart.
  Bytes state_packet(std::uint16_t hips, std::uint32_t sequence, std::uint32_t flags = 0)
  {
    Bytes p(32 + 72 * std::size_t(hips), 0);
    std::memcpy(p.data(), "MRTS", 4);
    put<std::uint16_t>(p, 4, 3);
    std::memset(p.data() + 16, 0x5A, 16);
    put<std::uint32_t>(p, 12, flags);
    put<std::uint16_t>(p, 6, hips);
    put<std::uint32_t>(p, 8, sequence);
    for (std::uint16_t h = 0; h < hips; ++h)
      {
        const double values[9] = {0.1 + 0.01 * h, 0.025, 0.015, 0.0, 0.0, -0.05, 0.0, 0.0, -1.5};
        for (int k = 0; k < 9; ++k)
          put<double>(p, 32 + 72 * std::size_t(h) + 8 * std::size_t(k), values[k]);
      }
    return p;
  }
} // namespace

int main(int argc, char **argv)
{
  if (argc != 2)
    {
      std::fprintf(stderr, "usage: make_udp_seed_corpus DIR\n");
      return 2;
    }
  const std::string dir = argv[1];
  bool              ok  = true;
  ok &= save(dir, "one_hip.bin", state_packet(1, 7));
  ok &= save(dir, "two_hips.bin", state_packet(2, 1000));
  ok &= save(dir, "sixteen_hips.bin", state_packet(16, 1));
  ok &= save(dir, "sequence_wraps.bin", state_packet(1, 0xFFFFFFFFu));
  ok &= save(dir, "hello.bin", state_packet(1, 0, 1u));
  ok &= save(dir, "bye.bin", state_packet(1, 20, 2u));
  ok &= save(dir, "bad_flag.bin", state_packet(1, 21, 1u << 5));
  Bytes old_client = state_packet(1, 22);
  put<std::uint16_t>(old_client, 4, 2); // protocol version 2 (no token): refused with BAD_VERSION
  old_client.erase(old_client.begin() + 16, old_client.begin() + 32);
  ok &= save(dir, "old_version.bin", old_client);
  Bytes wrong_token = state_packet(1, 23, 1u);
  wrong_token[31] ^= 1u; // a HELLO one bit off the token: refused with BAD_TOKEN
  ok &= save(dir, "bad_token_hello.bin", wrong_token);

  Bytes short_packet = state_packet(1, 8);
  short_packet.resize(short_packet.size() - 1);
  ok &= save(dir, "bad_short.bin", short_packet);
  Bytes long_packet = state_packet(1, 9);
  long_packet.push_back(0);
  ok &= save(dir, "bad_long.bin", long_packet);
  Bytes magic = state_packet(1, 10);
  magic[3] = 'C'; // a command packet's magic sent back
  ok &= save(dir, "bad_magic.bin", magic);
  Bytes version = state_packet(1, 11);
  put<std::uint16_t>(version, 4, 4);
  ok &= save(dir, "bad_version.bin", version);
  Bytes count = state_packet(1, 12);
  put<std::uint16_t>(count, 6, 2); // declares two HIPs, carries one
  ok &= save(dir, "bad_hip_count.bin", count);
  Bytes nan_force = state_packet(1, 13);
  put<double>(nan_force, 32 + 64, std::nan(""));
  ok &= save(dir, "bad_nan_force.bin", nan_force);
  Bytes inf_position = state_packet(2, 14);
  put<double>(inf_position, 32 + 72, std::numeric_limits<double>::infinity());
  ok &= save(dir, "bad_inf_position.bin", inf_position);
  ok &= save(dir, "bad_empty.bin", Bytes{});
  return ok ? 0 : 1;
}
