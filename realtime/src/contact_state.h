// A HIP's contact as the kernel keeps it: where it is on the part, its force, correction and
// coupling spring, its row B, and a sliding contact's proxy (proxy_state.h).
#pragma once

#include "proxy_state.h"

#include <modalrt/modalrt.h>

#include <cstdint>

namespace modalrt
{
  // One HIP's contact. B (3 x r, row-major, in the kernel's row buffer) maps the modal state to the
  // felt displacement u_c of the active vertex: the candidate's B_v, or sum_j w_j Phi_j over the patch.
  struct Contact
  {
    bool          in_contact = false;
    bool          armed      = true; // may snap (re-armed after having left the surface)
    std::uint32_t vertex     = MODALRT_NONE;
    int           candidate  = -1; // index among the active space's candidates, -1 if none
    double        rest[3]    = {0.0, 0.0, 0.0};
    double        normal[3]  = {0.0, 0.0, 0.0};
    double        force[3]   = {0.0, 0.0, 0.0}; // on the part during the last tick [N] body
    double        correction[3] = {0.0, 0.0, 0.0}; // sum_b C_ab F_b of the last tick [m] body
    double        anchor[3]  = {0.0, 0.0, 0.0}; // tangential offset of the HIP from the vertex at
                                                 // contact start [m] body: the coupling and the
                                                 // admittance output are anchored there, so a
                                                 // contact starts without a lateral jerk
    double        stiffness[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0}; // [N/m] body, row-major: the coupling spring
                                                              // (coupling.h, set_contact_stiffness)
    double       *B          = nullptr;
    ProxyState    proxy; // a sliding contact's proxy (proxy_contact.cc)
    // The validity map where the contact is (MODALRT_HIP_BEYOND_VALIDITY, validity_clamp).
    double validity_force     = 0.0;  // [N] at def.validity_level, this tick's (0: no value here)
    double validity_limit     = -1.0; // [N] validity_clamp's limit, following validity_force at most
                                      // force_rate_limit per tick (-1: not set since the contact began)
    double validity_unclamped = -1.0; // [N] |F| before validity_clamp this tick (-1: the clamp did not act)
  };
} // namespace modalrt
