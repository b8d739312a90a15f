#include "udp_device.h"

#include <arpa/inet.h>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace modalrt_tool
{
  namespace
  {
    // Little-endian fields (the kernel refuses big-endian machines too, so memcpy is the encoding).
    template <typename T> T load(const unsigned char *p)
    {
      T value;
      std::memcpy(&value, p, sizeof value);
      return value;
    }
    template <typename T> void store(unsigned char *p, T value) { std::memcpy(p, &value, sizeof value); }

    struct HipState
    {
      double position[3], velocity[3], force[3];
    };

    class UdpDevice final : public Device
    {
    public:
      explicit UdpDevice(const UdpSettings &settings)
        : settings_(settings), state_(settings.hips), command_(settings.hips, modalrt_hip_output{})
      {
        const modalrt_device_def d = modalrt_device_default_def();
        spec_ = DeviceSpec{"udp bridge (" + settings.bind_address + ":" + std::to_string(settings.port) + ")",
                           d.max_force, d.max_stiffness, d.max_damping, d.physical_damping};
        for (HipState &s : state_)
          for (int k = 0; k < 3; ++k)
            s.position[k] = settings.park[k], s.velocity[k] = 0.0, s.force[k] = 0.0;
      }
      ~UdpDevice() override { close(); }

      bool open(std::string &error) override
      {
        sockaddr_in address{};
        address.sin_family = AF_INET;
        address.sin_port   = htons(settings_.port);
        if (inet_pton(AF_INET, settings_.bind_address.c_str(), &address.sin_addr) != 1)
          {
            error = "'" + settings_.bind_address + "' is not an IPv4 address";
            return false;
          }
        socket_ = ::socket(AF_INET, SOCK_DGRAM, 0);
        if (socket_ < 0 || fcntl(socket_, F_SETFL, O_NONBLOCK) != 0 ||
            bind(socket_, reinterpret_cast<const sockaddr *>(&address), sizeof address) != 0)
          {
            error = "cannot listen on udp " + settings_.bind_address + ":" + std::to_string(settings_.port) + ": " +
                    std::strerror(errno);
            close();
            return false;
          }
        return true;
      }

      void close() override
      {
        if (socket_ >= 0)
          ::close(socket_);
        socket_ = -1;
      }

      const DeviceSpec &spec() const override { return spec_; }
      std::uint32_t     hip_count() const override { return settings_.hips; }

      void read_state(double, modalrt_hip_input *inputs) override
      {
        bool fresh = false;
        for (;;)
          {
            sockaddr_in    from{};
            socklen_t      length = sizeof from;
            const ssize_t  size   = recvfrom(socket_, buffer_, sizeof buffer_, MSG_DONTWAIT,
                                             reinterpret_cast<sockaddr *>(&from), &length);
            if (size < 0)
              break; // EAGAIN: drained (or an error: nothing to read either way)
            ++received_;
            fresh = accept(from, std::size_t(size)) || fresh;
          }
        ticks_since_fresh_ = fresh ? 0 : ticks_since_fresh_ + 1;
        silent_            = ticks_since_fresh_ >= settings_.silence_ticks;
        if (silent_)
          ++silent_ticks_;
        for (std::uint32_t h = 0; h < settings_.hips; ++h)
          for (int k = 0; k < 3; ++k)
            {
              inputs[h].position[k] = state_[h].position[k];
              // A silent device has no velocity to report and its user applies nothing we know of.
              inputs[h].velocity[k] = silent_ ? 0.0 : state_[h].velocity[k];
              inputs[h].force[k]    = silent_ ? 0.0 : state_[h].force[k];
            }
      }

      // The command packet carries the kernel's whole output; the mode only decides what the device
      // on the other side uses (the force or the position).
      void write_force(std::uint32_t, const double *) override {}
      void track_position(std::uint32_t, const double *, const double *, bool) override {}
      void report_output(std::uint32_t hip, const modalrt_hip_output &output) override { command_[hip] = output; }

      void end_tick() override
      {
        ++tick_;
        if (!has_peer_)
          return;
        unsigned char *p = buffer_;
        std::memcpy(p, "MRTC", 4);
        store<std::uint16_t>(p + 4, udp::version);
        store<std::uint16_t>(p + 6, std::uint16_t(settings_.hips));
        store<std::uint32_t>(p + 8, sequence_);
        store<std::uint32_t>(p + 12, silent_ ? udp::flag_silent : 0u);
        store<std::uint64_t>(p + 16, tick_);
        for (std::uint32_t h = 0; h < settings_.hips; ++h)
          {
            unsigned char  *q = p + udp::command_header + h * udp::command_per_hip;
            const modalrt_hip_output &c = command_[h];
            for (int k = 0; k < 3; ++k)
              {
                store<double>(q + 8 * k, silent_ ? 0.0 : c.force[k]);
                store<double>(q + 24 + 8 * k, c.position[k]);
                store<double>(q + 48 + 8 * k, c.velocity[k]);
              }
            store<std::uint32_t>(q + 72, c.in_contact);
            store<std::uint32_t>(q + 76, c.active_vertex);
            store<std::uint32_t>(q + 80, c.space);
            store<std::uint32_t>(q + 84, 0u);
          }
        const std::size_t size = udp::command_header + settings_.hips * udp::command_per_hip;
        if (sendto(socket_, p, size, MSG_DONTWAIT, reinterpret_cast<const sockaddr *>(&peer_), sizeof peer_) ==
            ssize_t(size))
          ++sent_;
        else
          ++send_errors_;
      }

      std::vector<std::pair<std::string, std::uint64_t>> counters() const override
      {
        return {{"packets_received", received_},   {"states_accepted", accepted_}, {"stale_packets", stale_},
                {"foreign_packets", foreign_},     {"bad_packets", bad_},          {"silent_ticks", silent_ticks_},
                {"commands_sent", sent_},          {"send_errors", send_errors_}};
      }

    private:
      // One datagram in buffer_: true if it is a fresh state from the peer (then copied in).
      bool accept(const sockaddr_in &from, std::size_t size)
      {
        if (has_peer_ && (from.sin_addr.s_addr != peer_.sin_addr.s_addr || from.sin_port != peer_.sin_port))
          {
            ++foreign_;
            return false;
          }
        if (!well_formed(size))
          {
            ++bad_;
            return false;
          }
        const std::uint32_t sequence = load<std::uint32_t>(buffer_ + 8);
        if (has_peer_ && std::int32_t(sequence - sequence_) <= 0)
          {
            ++stale_;
            return false;
          }
        for (std::uint32_t h = 0; h < settings_.hips; ++h)
          {
            const unsigned char *q = buffer_ + udp::state_header + h * udp::state_per_hip;
            for (int k = 0; k < 3; ++k)
              {
                state_[h].position[k] = load<double>(q + 8 * k);
                state_[h].velocity[k] = load<double>(q + 24 + 8 * k);
                state_[h].force[k]    = load<double>(q + 48 + 8 * k);
              }
          }
        sequence_ = sequence;
        peer_     = from;
        has_peer_ = true;
        ++accepted_;
        return true;
      }

      bool well_formed(std::size_t size) const
      {
        if (size != udp::state_header + settings_.hips * udp::state_per_hip || std::memcmp(buffer_, "MRTS", 4) != 0 ||
            load<std::uint16_t>(buffer_ + 4) != udp::version || load<std::uint16_t>(buffer_ + 6) != settings_.hips)
          return false;
        for (std::size_t k = 0; k < 9 * settings_.hips; ++k)
          if (!std::isfinite(load<double>(buffer_ + udp::state_header + 8 * k)))
            return false;
        return true;
      }

      UdpSettings           settings_;
      DeviceSpec            spec_;
      std::vector<HipState> state_;
      std::vector<modalrt_hip_output> command_;
      unsigned char         buffer_[udp::max_packet + 64]; // a bigger datagram is truncated, then refused
      int                   socket_   = -1;
      sockaddr_in           peer_{};
      bool                  has_peer_ = false;
      std::uint32_t         sequence_ = 0;
      std::uint64_t         tick_     = 0;
      std::uint32_t         ticks_since_fresh_ = 0;
      bool                  silent_            = true;
      std::uint64_t received_ = 0, accepted_ = 0, stale_ = 0, foreign_ = 0, bad_ = 0, silent_ticks_ = 0, sent_ = 0,
                    send_errors_ = 0;
    };
  } // namespace

  std::unique_ptr<Device> make_udp_device(const UdpSettings &settings) { return std::make_unique<UdpDevice>(settings); }
} // namespace modalrt_tool
