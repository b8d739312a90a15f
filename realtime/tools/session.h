// A scripted session for `modal-rt run`: a CSV file of timestamped keys and events (the format is
// documented in realtime/README.md, "Scripted sessions").
//
//   time,hip,event,x,y,z
//   0.0,0,target,0.0,0.05,0.030        # key of HIP 0's target position [m], world
//   0.5,0,force,0,0,-1                 # key of the force HIP 0's user applies [N], world
//   1.0,0,press,0.0,0.05,0.023         # contact now at the display vertex nearest this point [m], body
//   2.0,0,release,,,                   # release now
//   2.5,-,frame,0.0,0.0,0.1            # key of the part frame's origin [m], world
//   0.0,-,proxy,0.3,0.2                # contacts are sliding proxies, friction mu_s, mu_d (time 0, once)
//   6.0,-,end,,,                       # the session ends here
//
// With a second design (modal-rt run --design-b FILE.mrt):
//   3.0,-,design,B                     # the hand feels design B from now on (A: the first basis)
// and in the blind mode (--blind SEED), where the order of the two designs is drawn per trial:
//   3.0,-,trial                        # a trial starts: slot 1 and slot 2 hold A and B in random order
//   3.1,-,present,1                    # the hand feels the design in slot 1 (2: the other)
//   8.0,-,answer,2                     # the user's answer: slot 2 felt stiffer
//
// Keyed channels (target, force, frame) blend between consecutive keys with a minimum-jerk
// quintic, so positions, velocities and accelerations are continuous and the frame's acceleration
// (which drives the modes) is finite. Evaluation is cursor-based: no allocation, no search.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace modalrt_tool
{
  // A session file that cannot be used; the message names the file, the line and the value.
  struct SessionError : std::runtime_error
  {
    using std::runtime_error::runtime_error;
  };

  struct Key
  {
    double time;     // [s]
    double value[3]; // [m] or [N]
  };

  // A piecewise minimum-jerk curve through keys (sorted by time). Empty: the default value.
  struct Channel
  {
    std::vector<Key> keys;
    double           default_value[3] = {0.0, 0.0, 0.0};

    bool empty() const { return keys.empty(); }
  };

  // The value, velocity and acceleration of a channel at time t. `cursor` remembers the segment
  // between calls (times must not decrease), so a tick costs O(1).
  struct ChannelSample
  {
    double value[3], velocity[3], acceleration[3];
  };
  void sample(const Channel &channel, double t, std::size_t &cursor, ChannelSample &out);

  enum class EventKind
  {
    press,
    release,
    design,  // choice: 0 design A, 1 design B
    trial,   // the blind mode: a new trial, its order drawn
    present, // the blind mode: choice 1 or 2, the trial's slot felt from now on
    answer   // the blind mode: choice 1 or 2, the slot the user says felt stiffer
  };

  struct Event
  {
    double        time;     // [s]
    std::uint32_t hip;
    EventKind     kind;
    double        point[3]; // press: body-frame point [m]
    std::uint32_t vertex;   // press: the display vertex nearest `point` (resolved against the basis)
    int           line;     // in the session file, for messages
    std::uint32_t choice   = 0; // design, present, answer: see EventKind
    std::uint32_t vertex_b = 0; // press: the display vertex nearest `point` in the second design's basis
  };

  struct Session
  {
    std::string          path;
    std::uint32_t        hip_count = 0;
    std::vector<Channel> targets;  // per HIP [m] world
    std::vector<Channel> forces;   // per HIP [N] world
    Channel              frame;    // origin of the part's frame [m] world (empty: at rest at 0)
    std::vector<Event>   events;   // sorted by time
    double               end_time = 0.0; // [s] the `end` row, else the last row's time
    // The `proxy` row: the kernel's contacts are sliding proxies (MODALRT_CONTACT_PROXY) with these
    // Coulomb coefficients; else the snap contact.
    bool                 proxy            = false;
    double               static_friction  = 0.0; // [-] mu_s
    double               dynamic_friction = 0.0; // [-] mu_d
  };

  // Reads and checks a session file. Throws SessionError naming file, line and culprit.
  Session read_session(const std::string &path);

  // Resolves every press event to the display vertex nearest its point (vertices: 3 n [m]), of the
  // first design's basis (Event::vertex) or of the second's (Event::vertex_b).
  // Returns the largest distance from a press point to its vertex [m].
  double resolve_press_vertices(Session &session, const double *vertices, std::uint32_t vertex_count,
                                bool second_design = false);

  // How many rows of each kind of the two-design events the session has.
  struct DesignEventCount
  {
    std::size_t design = 0, trial = 0, present = 0, answer = 0;
  };
  DesignEventCount count_design_events(const Session &session);
} // namespace modalrt_tool
