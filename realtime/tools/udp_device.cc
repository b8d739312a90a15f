#include "udp_device.h"

#include <algorithm>
#include <arpa/inet.h>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <netinet/in.h>
#include <sys/random.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

namespace modalrt_tool
{
  namespace
  {
    using udp::HipState;

    // A directory for token files: made 0700 if missing; it must be ours and writable by nobody
    // else (another user could otherwise replace the file before the device reads it).
    bool private_directory(const std::string &directory, std::string &error)
    {
      struct stat status{};
      if ((mkdir(directory.c_str(), 0700) != 0 && errno != EEXIST) || lstat(directory.c_str(), &status) != 0)
        error = "cannot make the token directory " + directory + ": " + std::strerror(errno);
      else if (!S_ISDIR(status.st_mode) || status.st_uid != getuid() || (status.st_mode & 077) != 0)
        error = "the token directory " + directory + " is not a directory of this user's alone (mode 0700)";
      return error.empty();
    }

    // Writes the token as hexadecimal digits to `path`, atomically: a temporary file made by mkstemp
    // (mode 0600, O_EXCL) in the same directory, then renamed, so a reader never sees half a token
    // and no other user can have opened the file before it held the token.
    bool write_token_file(const std::string &path, const udp::Token &token, std::string &error)
    {
      std::string temporary = path + ".XXXXXX";
      const int   file      = mkstemp(&temporary[0]);
      if (file < 0)
        {
          error = "cannot create the token file " + path + ": " + std::strerror(errno);
          return false;
        }
      char hex[2 * udp::token_size + 1];
      udp::format_token(token, hex);
      hex[2 * udp::token_size] = '\n';
      const bool written       = fchmod(file, 0600) == 0 && ::write(file, hex, sizeof hex) == ssize_t(sizeof hex) &&
                           fsync(file) == 0;
      ::close(file);
      if (!written || rename(temporary.c_str(), path.c_str()) != 0)
        {
          error = "cannot write the token file " + path + ": " + std::strerror(errno);
          unlink(temporary.c_str());
          return false;
        }
      return true;
    }

    std::string address_text(const sockaddr_in &address)
    {
      char text[INET_ADDRSTRLEN] = "?";
      inet_ntop(AF_INET, &address.sin_addr, text, sizeof text);
      return std::string(text) + ":" + std::to_string(ntohs(address.sin_port));
    }

    class UdpDevice final : public Device
    {
    public:
      explicit UdpDevice(const UdpSettings &settings)
        : settings_(settings), state_(settings.hips), parked_(settings.hips), command_(settings.hips, modalrt_hip_output{})
      {
        const modalrt_device_def d = modalrt_device_default_def();
        spec_ = DeviceSpec{"udp bridge (" + settings.bind_address + ":" + std::to_string(settings.port) + ")",
                           d.max_force, d.max_stiffness, d.max_damping, d.physical_damping};
        timeout_ticks_ = std::max<std::uint64_t>(1, std::uint64_t(std::llround(settings.peer_timeout * settings.rate)));
        for (HipState &s : parked_)
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
        if (!prepare_token(error))
          {
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
        if (!token_path_.empty())
          unlink(token_path_.c_str());
        token_path_.clear();
        if (token_refusals_ > 0 && !refusals_logged_)
          std::printf("modal-rt serve: refused %llu packets without the bridge's token (the first from %s at tick %llu)\n",
                      (unsigned long long)token_refusals_, address_text(first_intruder_).c_str(),
                      (unsigned long long)first_intruder_tick_);
        refusals_logged_ = token_refusals_ > 0;
      }

      const DeviceSpec &spec() const override { return spec_; }
      std::uint32_t     hip_count() const override { return settings_.hips; }

      bool read_state(double, modalrt_hip_input *inputs) override
      {
        bool fresh = false;
        for (;;)
          {
            sockaddr_in   from{};
            socklen_t     length = sizeof from;
            const ssize_t size   = recvfrom(socket_, buffer_, sizeof buffer_, MSG_DONTWAIT,
                                            reinterpret_cast<sockaddr *>(&from), &length);
            if (size < 0)
              break; // EAGAIN: drained (or an error: nothing to read either way)
            ++received_;
            fresh = accept(from, std::size_t(size)) || fresh;
          }
        ticks_since_fresh_ = fresh ? 0 : ticks_since_fresh_ + 1;
        if (has_peer_ && ticks_since_fresh_ >= timeout_ticks_)
          end_session(peer_timeouts_); // the peer is gone: the next device may take the slot
        if (!has_peer_)
          {
            // Nobody holds the slot: not a missing tick (no device to fail), the HIPs wait parked.
            copy_inputs(parked_, inputs);
            return true;
          }
        if (!fresh)
          {
            ++missing_;
            return false;
          }
        copy_inputs(state_, inputs);
        return true;
      }

      int requested_design() const override { return has_peer_ ? (design_b_ ? 1 : 0) : -1; }

      bool take_session_change() override
      {
        const bool changed = session_changed_;
        session_changed_   = false;
        return changed;
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
        send(peer_, udp::encode_command(buffer_, settings_.hips, sequence_, tick_, command_.data()));
      }

      std::vector<std::pair<std::string, std::uint64_t>> counters() const override
      {
        return {{"packets_received", received_}, {"states_accepted", accepted_}, {"stale_packets", stale_},
                {"foreign_packets", foreign_},   {"bad_packets", bad_},          {"bad_version_packets", bad_version_},
                {"refusals_sent", refusals_},    {"sessions", sessions_},        {"hellos", hellos_},
                {"byes", byes_},                 {"peer_timeouts", peer_timeouts_}, {"takeovers", takeovers_},
                {"restarts", restarts_},         {"missing_ticks", missing_},   {"commands_sent", sent_},
                {"send_errors", send_errors_},   {"token_refusals", token_refusals_}};
      }

    private:
      // The token: --token's, or 128 bits from the kernel's random source; written to the token file
      // unless it was given without --token-file.
      bool prepare_token(std::string &error)
      {
        token_ = settings_.token;
        if (!settings_.token_given && getrandom(token_.bytes, sizeof token_.bytes, 0) != ssize_t(sizeof token_.bytes))
          {
            error = std::string("cannot draw a random token: ") + std::strerror(errno);
            return false;
          }
        if (settings_.token_given && settings_.token_file.empty())
          {
            std::printf("modal-rt serve: udp %s:%u, the token given by --token\n", settings_.bind_address.c_str(),
                        unsigned(settings_.port));
            std::fflush(stdout);
            return true;
          }
        const std::string path = settings_.token_file.empty() ? default_token_file(settings_.port) : settings_.token_file;
        if (path.empty())
          {
            error = "no private directory for the token file (give --token-file PATH)";
            return false;
          }
        if (!write_token_file(path, token_, error))
          return false;
        token_path_ = path;
        std::printf("modal-rt serve: udp %s:%u, token in %s (mode 0600, removed at exit)\n",
                    settings_.bind_address.c_str(), unsigned(settings_.port), path.c_str());
        std::fflush(stdout);
        return true;
      }

      void send(const sockaddr_in &to, std::size_t size)
      {
        if (sendto(socket_, buffer_, size, MSG_DONTWAIT, reinterpret_cast<const sockaddr *>(&to), sizeof to) ==
            ssize_t(size))
          ++sent_;
        else
          ++send_errors_;
      }

      // A refusal echoes the refused packet's sequence number (0 if it has none) and carries the
      // bridge's tick count (realtime/README.md).
      void refuse(const sockaddr_in &to, std::uint32_t sequence, std::uint32_t flags)
      {
        ++refusals_;
        send(to, udp::encode_refusal(buffer_, sequence, flags, tick_));
      }

      static bool same_sender(const sockaddr_in &a, const sockaddr_in &b)
      {
        return a.sin_addr.s_addr == b.sin_addr.s_addr && a.sin_port == b.sin_port;
      }

      // One datagram in buffer_: true if it is a fresh state from the peer (then copied in).
      bool accept(const sockaddr_in &from, std::size_t size)
      {
        const bool    from_peer = has_peer_ && same_sender(from, peer_);
        std::uint32_t sequence = 0, flags = 0;
        HipState      decoded[udp::max_hips];
        switch (udp::decode_state(buffer_, size, settings_.hips, token_, sequence, flags, decoded))
          {
            case udp::Verdict::bad_version:
              ++bad_version_;
              refuse(from, udp::sequence_of(buffer_, size), udp::command_bad_version);
              return false;
            case udp::Verdict::bad_token:
              refuse_intruder(from, udp::sequence_of(buffer_, size));
              return false;
            case udp::Verdict::bad:
              ++bad_;
              return false;
            case udp::Verdict::good:
              break;
          }
        const bool hello = (flags & udp::state_hello) != 0, bye = (flags & udp::state_bye) != 0;
        hellos_ += hello ? 1 : 0;
        if (has_peer_ && !from_peer && (!hello || bye))
          {
            ++foreign_;
            refuse(from, sequence, udp::command_refused);
            return false;
          }
        if (bye)
          {
            if (from_peer)
              end_session(byes_);
            return false;
          }
        if (from_peer && !hello && !udp::in_window(sequence, sequence_) && !counter_restarted(sequence))
          {
            ++stale_;
            return false;
          }
        // A HELLO with the token from another address or port is the user's own driver restarted on
        // a new socket: it replaces the peer at once.
        takeovers_ += has_peer_ && !from_peer ? 1 : 0;
        if (!from_peer || hello)
          start_session();
        restart_run_ = 0;
        std::copy_n(decoded, settings_.hips, state_.begin());
        design_b_ = (flags & udp::state_design_b) != 0;
        sequence_ = sequence;
        peer_     = from;
        has_peer_ = true;
        ++accepted_;
        return true;
      }

      // A well-formed packet without the bridge's token: refused and counted, never served; the first
      // sender is kept for the log (written at close, not in the tick).
      void refuse_intruder(const sockaddr_in &from, std::uint32_t sequence)
      {
        if (token_refusals_++ == 0)
          first_intruder_ = from, first_intruder_tick_ = tick_;
        refuse(from, sequence, udp::command_bad_token);
      }

      // The peer restarted its counter without HELLO: `restart_length` consecutive numbers (each one
      // ahead of the one before) outside the window of the reference. One stale packet, or a repeated
      // pair (a reordered burst), is not enough.
      bool counter_restarted(std::uint32_t sequence)
      {
        restart_run_  = restart_run_ > 0 && sequence == restart_last_ + 1 ? restart_run_ + 1 : 1;
        restart_last_ = sequence;
        if (restart_run_ < udp::restart_length)
          return false;
        ++restarts_;
        session_changed_ = true;
        return true;
      }

      void start_session()
      {
        ++sessions_;
        session_changed_ = true;
      }

      void end_session(std::uint64_t &reason)
      {
        ++reason;
        has_peer_        = false;
        session_changed_ = true;
      }

      void copy_inputs(const std::vector<HipState> &from, modalrt_hip_input *inputs) const
      {
        for (std::uint32_t h = 0; h < settings_.hips; ++h)
          for (int k = 0; k < 3; ++k)
            {
              inputs[h].position[k] = from[h].position[k];
              inputs[h].velocity[k] = from[h].velocity[k];
              inputs[h].force[k]    = from[h].force[k];
            }
      }

      UdpSettings           settings_;
      DeviceSpec            spec_;
      std::vector<HipState> state_, parked_;
      std::vector<modalrt_hip_output> command_;
      unsigned char         buffer_[udp::max_packet + 64]; // a bigger datagram is truncated, then refused
      int                   socket_   = -1;
      sockaddr_in           peer_{};
      bool                  has_peer_ = false;
      bool                  design_b_ = false; // the peer's last state asked for design B (state_design_b)
      std::uint32_t         sequence_ = 0;
      std::uint64_t         tick_     = 0;
      std::uint64_t         ticks_since_fresh_ = 0;
      std::uint64_t         timeout_ticks_     = 1;
      udp::Token            token_{};
      std::string           token_path_; // the token file written at open, removed at close
      sockaddr_in           first_intruder_{};
      std::uint64_t         first_intruder_tick_ = 0, token_refusals_ = 0;
      bool                  refusals_logged_     = false;
      bool                  session_changed_   = false;
      std::uint32_t         restart_run_ = 0, restart_last_ = 0; // consecutive numbers outside the window
      std::uint64_t received_ = 0, accepted_ = 0, stale_ = 0, foreign_ = 0, bad_ = 0, bad_version_ = 0, refusals_ = 0,
                    sessions_ = 0, hellos_ = 0, byes_ = 0, peer_timeouts_ = 0, missing_ = 0, sent_ = 0,
                    send_errors_ = 0, takeovers_ = 0, restarts_ = 0;
    };
  } // namespace

  std::string default_token_file(std::uint16_t port)
  {
    const char *runtime   = std::getenv("XDG_RUNTIME_DIR");
    std::string directory = runtime && *runtime ? std::string(runtime) + "/modal-rt"
                                                : "/tmp/modal-rt-" + std::to_string(getuid());
    std::string error;
    if (!private_directory(directory, error))
      {
        std::fprintf(stderr, "modal-rt serve: %s\n", error.c_str());
        return "";
      }
    return directory + "/serve-" + std::to_string(port) + ".token";
  }

  std::unique_ptr<Device> make_udp_device(const UdpSettings &settings) { return std::make_unique<UdpDevice>(settings); }
} // namespace modalrt_tool
