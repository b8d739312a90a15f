#include "devices.h"

#include <cmath>

namespace modalrt_tool
{
  DeviceSpec default_device_spec(const char *name)
  {
    const modalrt_device_def d = modalrt_device_default_def();
    return DeviceSpec{name, d.max_force, d.max_stiffness, d.max_damping, d.physical_damping};
  }

  void park_position(const modalrt_basis_info &info, double park[3])
  {
    park[0] = 0.5 * (info.bounds_min[0] + info.bounds_max[0]);
    park[1] = 0.5 * (info.bounds_min[1] + info.bounds_max[1]);
    park[2] = info.bounds_max[2] + 0.5;
  }

  namespace
  {
    // The scripted channels of every HIP, sampled with cursors (no search, no allocation).
    class ScriptReader
    {
    public:
      explicit ScriptReader(const Session &session)
        : session_(session), target_cursor_(session.hip_count, 0), force_cursor_(session.hip_count, 0)
      {}

      void target(std::uint32_t hip, double t, ChannelSample &out)
      {
        sample(session_.targets[hip], t, target_cursor_[hip], out);
      }
      void force(std::uint32_t hip, double t, ChannelSample &out) { sample(session_.forces[hip], t, force_cursor_[hip], out); }
      std::uint32_t hip_count() const { return session_.hip_count; }

    private:
      const Session           &session_;
      std::vector<std::size_t> target_cursor_, force_cursor_;
    };

    class ScriptedProbe final : public Device
    {
    public:
      explicit ScriptedProbe(const Session &session) : script_(session), spec_(default_device_spec("scripted probe")) {}

      bool open(std::string &) override { return true; }
      void close() override {}
      const DeviceSpec &spec() const override { return spec_; }
      std::uint32_t     hip_count() const override { return script_.hip_count(); }

      bool read_state(double t, modalrt_hip_input *inputs) override
      {
        for (std::uint32_t h = 0; h < script_.hip_count(); ++h)
          {
            ChannelSample target, force;
            script_.target(h, t, target);
            script_.force(h, t, force);
            for (int d = 0; d < 3; ++d)
              {
                inputs[h].position[d] = target.value[d];
                inputs[h].velocity[d] = target.velocity[d];
                inputs[h].force[d]    = force.value[d];
              }
          }
        return true;
      }
      // A rigid probe: what it renders or tracks does not move it.
      void write_force(std::uint32_t, const double *) override {}
      void track_position(std::uint32_t, const double *, const double *, bool) override {}

    private:
      ScriptReader script_;
      DeviceSpec   spec_;
    };

    class SimulatedHand final : public Device
    {
    public:
      SimulatedHand(const Session &session, double time_step)
        : script_(session), spec_(default_device_spec("simulated hand")), time_step_(time_step), hips_(session.hip_count)
      {}

      bool open(std::string &error) override
      {
        if (!(time_step_ > 0.0))
          {
            error = "simulated hand: the time step must be > 0";
            return false;
          }
        started_ = false;
        return true;
      }
      void              close() override {}
      const DeviceSpec &spec() const override { return spec_; }
      std::uint32_t     hip_count() const override { return script_.hip_count(); }

      bool read_state(double t, modalrt_hip_input *inputs) override
      {
        for (std::uint32_t h = 0; h < script_.hip_count(); ++h)
          {
            ChannelSample target, force;
            script_.target(h, t, target);
            script_.force(h, t, force);
            Hip &hip = hips_[h];
            if (!started_)
              for (int d = 0; d < 3; ++d)
                hip.x[d] = target.value[d], hip.v[d] = 0.0;
            else if (!hip.tracking)
              step(hip, target, force);
            for (int d = 0; d < 3; ++d)
              {
                inputs[h].position[d] = hip.x[d];
                inputs[h].velocity[d] = hip.v[d];
                // The force on the part (admittance): the hand's pull plus the scripted push.
                inputs[h].force[d] = params_.stiffness * (target.value[d] - hip.x[d]) +
                                     params_.damping * (target.velocity[d] - hip.v[d]) + force.value[d];
              }
          }
        started_ = true;
        return true;
      }

      void write_force(std::uint32_t hip, const double *force) override
      {
        for (int d = 0; d < 3; ++d)
          hips_[hip].device_force[d] = force[d];
      }

      void track_position(std::uint32_t hip, const double *position, const double *velocity, bool in_contact) override
      {
        Hip &h     = hips_[hip];
        h.tracking = in_contact;
        if (in_contact)
          for (int d = 0; d < 3; ++d)
            h.x[d] = position[d], h.v[d] = velocity[d];
      }

    private:
      struct Hip
      {
        double x[3] = {0, 0, 0}, v[3] = {0, 0, 0}, device_force[3] = {0, 0, 0};
        bool   tracking = false; // admittance contact: the device imposes the position
      };

      // One step of m v' = k (x_t - x) + c (v_t - v) + F_user + F_device, implicit in the hand's
      // spring and damper (unconditionally stable for them) and explicit in the device force.
      void step(Hip &hip, const ChannelSample &target, const ChannelSample &force) const
      {
        const double T = time_step_, m = params_.mass, k = params_.stiffness, c = params_.damping;
        for (int d = 0; d < 3; ++d)
          {
            const double push = k * (target.value[d] - hip.x[d]) + c * target.velocity[d] + force.value[d] +
                                hip.device_force[d];
            hip.v[d] = (m / T * hip.v[d] + push) / (m / T + k * T + c);
            hip.x[d] += T * hip.v[d];
          }
      }

      ScriptReader     script_;
      DeviceSpec       spec_;
      HandParameters   params_;
      double           time_step_;
      std::vector<Hip> hips_;
      bool             started_ = false;
    };
  } // namespace

  std::unique_ptr<Device> make_device(DeviceKind kind, const Session &session, double time_step)
  {
    if (kind == DeviceKind::probe)
      return std::make_unique<ScriptedProbe>(session);
    return std::make_unique<SimulatedHand>(session, time_step);
  }
} // namespace modalrt_tool
