// The C API: argument checks, exceptions turned into status codes and messages, and defaults.
#include "basis_loader.h"
#include "display.h"
#include "error.h"
#include "kernel.h"
#include "self_check.h"

#include <modalrt/modalrt.h>
#include <mrt/device_defaults.h>
#include <mrt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__SSE__) || defined(_M_X64) || defined(__x86_64__)
#  include <xmmintrin.h>
#  define MODALRT_HAVE_MXCSR 1
#endif

using namespace modalrt;

namespace
{
  int invalid(const std::string &message)
  {
    set_last_error(message);
    return MODALRT_ERROR_INVALID_ARGUMENT;
  }

  // The static compliance of a load spread over display vertices with weights: B Lambda^-1 B^T with
  // B = sum_k w_k B_k (a candidate's stored block, else its patch row: the kernel's contact rows),
  // taken in pieces of `piece` modes so that no 3 x r buffer is allocated, plus the residual the
  // kernel gives that load (blended_residual). full_fe: every weighted corner a candidate, and every
  // pair of them coupled exactly (own or stored blocks, not the far field).
  int blended_compliance(const char *function, const modalrt_basis &basis, const ModalSpace &space,
                         const std::uint32_t *vertices, const double *weights, int count, double G[9],
                         std::uint32_t *full_fe)
  {
    // Eigenvalues are ascending: one check covers every mode.
    if (space.mode_count > 0 && !(space.eigenvalues.front() > 0.0))
      {
        set_last_error((std::string(function) + ": the space has a mode with omega = 0: no static compliance").c_str());
        return MODALRT_ERROR_VALUE;
      }
    constexpr std::uint32_t piece = 32;
    const std::uint32_t     r     = space.mode_count;
    LoadCorner              corners[3];
    int                     weighted = 0;
    bool                    all_candidates = true;
    for (int k = 0; k < count; ++k)
      {
        corners[k] = {space.candidate_index(vertices[k]), weights[k]};
        if (weights[k] > 0.0)
          ++weighted, all_candidates = all_candidates && corners[k].candidate >= 0;
      }
    std::fill_n(G, 9, 0.0);
    double B[3 * piece], row[3 * piece];
    for (std::uint32_t begin = 0; begin < r; begin += piece)
      {
        const std::uint32_t end = std::min(r, begin + piece), n = end - begin;
        std::fill_n(B, 3 * n, 0.0);
        for (int k = 0; k < count; ++k)
          {
            if (weights[k] == 0.0)
              continue;
            if (corners[k].candidate >= 0)
              for (int c = 0; c < 3; ++c)
                std::copy_n(&space.candidate_modes[(3 * std::size_t(corners[k].candidate) + c) * r + begin], n, &row[c * n]);
            else
              patch_row(basis, space, vertices[k], begin, end, row);
            for (std::uint32_t i = 0; i < 3 * n; ++i)
              B[i] += weights[k] * row[i];
          }
        for (std::uint32_t i = 0; i < n; ++i)
          for (int c = 0; c < 3; ++c)
            for (int d = 0; d < 3; ++d)
              G[3 * c + d] += B[c * n + i] * B[d * n + i] / space.eigenvalues[begin + i];
      }
    double     C[9];
    const bool exact_pairs = blended_residual(space, corners, count, corners, count, true, C);
    for (int k = 0; k < 9; ++k)
      G[k] += C[k];
    if (full_fe)
      *full_fe = all_candidates && exact_pairs ? 1u : 0u;
    return MODALRT_OK;
  }

  int null_kernel(const char *function)
  {
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, function);
  }

  // The residual coupling of two display vertices of a space (none unless both are candidates).
  ModalSpace::Coupling vertex_pair_coupling(const ModalSpace &s, std::uint32_t vertex_a, std::uint32_t vertex_b,
                                            double C[9])
  {
    const int ca = s.candidate_index(vertex_a), cb = s.candidate_index(vertex_b);
    return ca >= 0 && cb >= 0 ? s.residual_coupling(std::uint32_t(ca), std::uint32_t(cb), C)
                              : ModalSpace::Coupling::none;
  }
} // namespace

extern "C" {

const char *modalrt_status_name(int status)
{
  switch (status)
    {
      case MODALRT_OK: return "MODALRT_OK";
      case MODALRT_INPUT_REJECTED: return "MODALRT_INPUT_REJECTED";
      case MODALRT_ERROR_INVALID_ARGUMENT: return "MODALRT_ERROR_INVALID_ARGUMENT";
      case MODALRT_ERROR_IO: return "MODALRT_ERROR_IO";
      case MODALRT_ERROR_FORMAT: return "MODALRT_ERROR_FORMAT";
      case MODALRT_ERROR_CHECKSUM: return "MODALRT_ERROR_CHECKSUM";
      case MODALRT_ERROR_VALUE: return "MODALRT_ERROR_VALUE";
      case MODALRT_ERROR_OUT_OF_MEMORY: return "MODALRT_ERROR_OUT_OF_MEMORY";
      case MODALRT_ERROR_DEVICE_LIMIT: return "MODALRT_ERROR_DEVICE_LIMIT";
      case MODALRT_ERROR_STATE: return "MODALRT_ERROR_STATE";
      case MODALRT_ERROR_VERIFY_FAILED: return "MODALRT_ERROR_VERIFY_FAILED";
      default: return "MODALRT_UNKNOWN_STATUS";
    }
}

uint32_t modalrt_version(void) { return MODALRT_VERSION_MAJOR * 1000u + MODALRT_VERSION_MINOR; }

int modalrt_thread_enable_flush_to_zero(void)
{
#if defined(MODALRT_HAVE_MXCSR)
  _mm_setcsr(_mm_getcsr() | 0x8040u); // FTZ (bit 15) and DAZ (bit 6)
  return 1;
#else
  return 0;
#endif
}

// ----- basis -----------------------------------------------------------------------------------
int modalrt_basis_load(const char *path, modalrt_basis **basis)
{
  if (!path || !basis)
    return invalid("modalrt_basis_load: null argument");
  *basis = nullptr;
  return guarded([&] {
    *basis = load_basis_file(path).release();
    return MODALRT_OK;
  });
}

int modalrt_basis_load_memory(const void *bytes, size_t size, modalrt_basis **basis)
{
  if ((!bytes && size > 0) || !basis)
    return invalid("modalrt_basis_load_memory: null argument");
  *basis = nullptr;
  return guarded([&] {
    *basis = load_basis_memory(bytes, size).release();
    return MODALRT_OK;
  });
}

void modalrt_basis_destroy(modalrt_basis *basis) { delete basis; }

int modalrt_basis_get_info(const modalrt_basis *basis, modalrt_basis_info *info)
{
  if (!basis || !info)
    return invalid("modalrt_basis_get_info: null argument");
  modalrt_basis_info i{};
  i.version_major          = basis->version_major;
  i.version_minor          = basis->version_minor;
  i.file_bytes             = basis->file_bytes;
  i.section_count          = std::uint32_t(basis->sections.size());
  i.space_count            = basis->space_count();
  i.display_vertex_count   = basis->vertex_count;
  i.display_triangle_count = basis->triangle_count;
  i.max_modes              = basis->max_modes;
  i.max_patch_size         = basis->max_patch_size;
  i.mode_scalar_bytes      = basis->float64_modes() ? 8 : 4;
  i.patch_radius           = basis->patch_radius();
  i.mass                   = basis->mass();
  std::copy_n(basis->centre_of_mass(), 3, i.centre_of_mass);
  std::copy_n(basis->inertia(), 9, i.inertia);
  std::copy_n(basis->bounds_min, 3, i.bounds_min);
  std::copy_n(basis->bounds_max, 3, i.bounds_max);
  *info = i;
  return MODALRT_OK;
}

int modalrt_basis_get_space_info(const modalrt_basis *basis, uint32_t space, modalrt_space_info *info)
{
  if (!basis || !info || space >= basis->space_count())
    return invalid("modalrt_basis_get_space_info: null argument or space out of range");
  const ModalSpace  &s = basis->spaces[space];
  modalrt_space_info i{};
  const std::size_t  n = std::min(s.name.size(), sizeof(i.name) - 1);
  std::memcpy(i.name, s.name.data(), n);
  i.mode_count        = s.mode_count;
  i.candidate_count   = s.candidate_count;
  i.validation_count  = s.validation_count;
  i.cross_count       = s.cross_count;
  i.has_participation = s.participation.empty() ? 0 : 1;
  i.far_rank          = s.far_rank;
  const double two_pi = 6.283185307179586476925;
  i.lowest_frequency  = std::sqrt(s.eigenvalues.front()) / two_pi;
  i.highest_frequency = std::sqrt(s.eigenvalues.back()) / two_pi;
  *info               = i;
  return MODALRT_OK;
}

const double *modalrt_basis_eigenvalues(const modalrt_basis *basis, uint32_t space)
{
  return basis && space < basis->space_count() ? basis->spaces[space].eigenvalues.data() : nullptr;
}

const double *modalrt_basis_damping_ratios(const modalrt_basis *basis, uint32_t space)
{
  return basis && space < basis->space_count() ? basis->spaces[space].damping_ratios.data() : nullptr;
}

const uint32_t *modalrt_basis_candidates(const modalrt_basis *basis, uint32_t space)
{
  return basis && space < basis->space_count() ? basis->spaces[space].candidates.data() : nullptr;
}

const double   *modalrt_basis_display_vertices(const modalrt_basis *basis) { return basis ? basis->vertices.data() : nullptr; }
const uint32_t *modalrt_basis_display_triangles(const modalrt_basis *basis) { return basis ? basis->triangles.data() : nullptr; }
const uint32_t *modalrt_basis_display_regions(const modalrt_basis *basis) { return basis ? basis->region.data() : nullptr; }
const double   *modalrt_basis_display_normals(const modalrt_basis *basis) { return basis ? basis->normals.data() : nullptr; }

int modalrt_basis_pair_is_exact(const modalrt_basis *basis, uint32_t space, uint32_t a, uint32_t b)
{
  double C[9];
  return basis && space < basis->space_count() &&
             vertex_pair_coupling(basis->spaces[space], a, b, C) == ModalSpace::Coupling::exact
           ? 1
           : 0;
}

int modalrt_basis_pair_coupling(const modalrt_basis *basis, uint32_t space, uint32_t vertex_a, uint32_t vertex_b,
                                double C[9])
{
  if (!basis || space >= basis->space_count() || vertex_a >= basis->vertex_count || vertex_b >= basis->vertex_count)
    return invalid("modalrt_basis_pair_coupling: null basis, space or vertex out of range");
  double     block[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  const auto coupling = vertex_pair_coupling(basis->spaces[space], vertex_a, vertex_b, block);
  if (C)
    std::copy_n(block, 9, C);
  return coupling == ModalSpace::Coupling::exact ? MODALRT_COUPLING_EXACT
         : coupling == ModalSpace::Coupling::far ? MODALRT_COUPLING_FAR
                                                 : MODALRT_COUPLING_NONE;
}

const double *modalrt_basis_felt_stiffness(const modalrt_basis *basis, uint32_t space)
{
  if (!basis || space >= basis->space_count() || basis->spaces[space].felt_stiffness.empty())
    return nullptr;
  return basis->spaces[space].felt_stiffness.data();
}

int modalrt_basis_contact_compliance(const modalrt_basis *basis, uint32_t space, uint32_t vertex, double compliance[9],
                                     uint32_t *full_fe)
{
  if (!basis || !compliance || space >= basis->space_count() || vertex >= basis->vertex_count)
    return invalid("modalrt_basis_contact_compliance: null argument, space or vertex out of range");
  const double weight = 1.0;
  return blended_compliance("modalrt_basis_contact_compliance", *basis, basis->spaces[space], &vertex, &weight, 1,
                            compliance, full_fe);
}

namespace
{
  // Barycentric weights of a point of a triangle: each in 0 .. 1, summing to 1 within 1e-9. The
  // message names the function.
  int check_point_weights(const char *function, const double weights[3])
  {
    double sum = 0.0;
    for (int k = 0; k < 3; ++k)
      {
        if (!(weights[k] >= 0.0 && weights[k] <= 1.0))
          return invalid(cat(function, ": a weight is negative, above 1 or not finite"));
        sum += weights[k];
      }
    if (!(std::fabs(sum - 1.0) <= 1e-9))
      return invalid(cat(function, ": the weights do not sum to 1"));
    return MODALRT_OK;
  }
} // namespace

int modalrt_basis_point_compliance(const modalrt_basis *basis, uint32_t space, uint32_t triangle, const double weights[3],
                                   double compliance[9], uint32_t *full_fe)
{
  if (!basis || !weights || !compliance || space >= basis->space_count() || triangle >= basis->triangle_count)
    return invalid("modalrt_basis_point_compliance: null argument, space or triangle out of range");
  if (const int status = check_point_weights("modalrt_basis_point_compliance", weights))
    return status;
  return blended_compliance("modalrt_basis_point_compliance", *basis, basis->spaces[space],
                            &basis->triangles[3 * std::size_t(triangle)], weights, 3, compliance, full_fe);
}

const double *modalrt_basis_validity_forces(const modalrt_basis *basis, uint32_t space)
{
  if (!basis || space >= basis->space_count() || basis->spaces[space].validity_force.empty())
    return nullptr;
  return basis->spaces[space].validity_force.data();
}

int modalrt_basis_point_validity_force(const modalrt_basis *basis, uint32_t space, uint32_t triangle,
                                       const double weights[3], uint32_t level_percent, double *force)
{
  if (!basis || !weights || !force || space >= basis->space_count() || triangle >= basis->triangle_count)
    return invalid("modalrt_basis_point_validity_force: null argument, space or triangle out of range");
  const int level = validity_level_index(level_percent);
  if (level < 0)
    return invalid(cat("modalrt_basis_point_validity_force: level_percent = ", level_percent, ", expected 1, 5 or 10"));
  if (const int status = check_point_weights("modalrt_basis_point_validity_force", weights))
    return status;
  *force = blended_validity_force(basis->spaces[space], &basis->triangles[3 * std::size_t(triangle)], weights, 3, level);
  return MODALRT_OK;
}

int modalrt_basis_has_transfer(const modalrt_basis *basis, uint32_t to, uint32_t from)
{
  if (!basis || to >= basis->space_count() || from >= basis->space_count() || to == from)
    return 0;
  return basis->transfer(to, from).empty() ? 0 : 1;
}

int modalrt_basis_get_section(const modalrt_basis *basis, uint32_t index, modalrt_section_info *info)
{
  if (!basis || !info || index >= basis->sections.size())
    return invalid("modalrt_basis_get_section: null argument or index out of range");
  const SectionRecord &s = basis->sections[index];
  modalrt_section_info i{};
  std::strncpy(i.name, format::kind_name(s.kind), sizeof(i.name) - 1);
  i.kind         = s.kind;
  i.space        = s.space;
  i.source_space = s.source_space;
  i.scalar_type  = s.scalar_type;
  i.offset       = s.offset;
  i.count        = s.count;
  i.bytes        = s.count * format::scalar_bytes(s.scalar_type);
  *info          = i;
  return MODALRT_OK;
}

int modalrt_basis_verify_case(const modalrt_basis *basis, uint32_t index, modalrt_verify_case *result)
{
  if (!basis || !result)
    return invalid("modalrt_basis_verify_case: null argument");
  return guarded([&] {
    verify_case(*basis, index, *result);
    return MODALRT_OK;
  });
}

int modalrt_basis_verify(const modalrt_basis *basis, modalrt_verify_report *report)
{
  if (!basis || !report)
    return invalid("modalrt_basis_verify: null argument");
  return guarded([&] {
    const int status = verify(*basis, *report);
    if (status != MODALRT_OK)
      set_last_error(cat(basis->source, ": self-check failed: max relative error ", report->max_relative_error,
                         " > tolerance ", report->tolerance, " (case ", report->worst_case, ")"));
    return status;
  });
}

// ----- kernel ----------------------------------------------------------------------------------
modalrt_device_def modalrt_device_default_def(void)
{
  modalrt_device_def d{};
  d.max_force        = mrt::default_max_force; // N
  d.max_stiffness    = 3000.0; // N/m at 1 kHz
  d.max_damping      = 10.0;   // N s/m
  d.physical_damping = 0.0;    // unknown
  d.rate             = 1000.0; // Hz
  d.kind             = MODALRT_DEVICE_IMPEDANCE;
  return d;
}

modalrt_kernel_def modalrt_kernel_default_def(void)
{
  modalrt_kernel_def d{};
  d.time_step              = 1e-3; // 1 kHz
  d.hip_capacity           = 4;
  d.initial_space          = 0;
  d.device                 = modalrt_device_default_def();
  d.coupling_stiffness     = 1000.0; // N/m
  d.coupling_damping       = 2.0;    // N s/m: K T / 2 = 0.5 < 2
  d.snap_distance          = 0.01;   // m
  d.contact_tolerance      = 0.0;    // m
  d.release_distance       = 1e-3;   // m
  d.release_force          = 0.05;   // N
  d.max_input_force        = 1000.0; // N
  d.workspace_radius       = 10.0;   // m
  d.max_input_velocity     = 100.0;  // m/s
  d.max_frame_acceleration = 1e4;    // m/s^2, rad/s^2
  d.snap_candidate_budget  = 16;
  d.switch_rule            = MODALRT_SWITCH_AT_CONTACT_START;
  d.carry_state_on_switch  = 1;
  d.use_static_correction  = 1;
  d.auto_release           = 1;
  d.snapshot_interval      = 1;
  d.enable_profile         = 0;
  d.validity_level         = 0; // the 5 % level
  d.release_drag_distance  = 0.01; // m: 1000 N/m x 0.01 m = the default device's 10 N
  d.fail_safe_hold         = 0.5; // s: twice the longest gap of a 1 kHz client measured here (docs/reliability.md)
  d.fail_safe_ramp         = 0.05; // s
  d.force_rate_limit       = 0.2;  // N per tick: the default device's 10 N in 50 ticks (the fail-safe ramp's slope)
  d.grasp                  = 0;    // a contact pushes, it does not pull
  d.validity_clamp         = 0; // the force is not limited to the validity force
  d.contact_mode           = MODALRT_CONTACT_SNAP;
  d.proxy_row_memory       = 0;
  d.static_friction        = 0.3; // a dry finger on a moulded plastic part, roughly
  d.dynamic_friction       = 0.2;
  d.haptic_scale           = 0.0; // no scale: the coupling spring in series with the part
  d.workspace_scale        = 0.0; // 1: the device's metre is the part's
  d.coupling_multiple      = 0.0; // 200 with a scale
  d.passivity_control      = 1;   // no device publishes its physical damping: b = 0 fails Colgate & Schenkel
  return d;
}

int modalrt_kernel_create(const modalrt_basis *basis, const modalrt_kernel_def *def, modalrt_kernel **kernel)
{
  if (!basis || !def || !kernel)
    return invalid("modalrt_kernel_create: null argument");
  *kernel = nullptr;
  return guarded([&] {
    *kernel = new modalrt_kernel(*basis, *def);
    return MODALRT_OK;
  });
}

void modalrt_kernel_destroy(modalrt_kernel *kernel) { delete kernel; }

int modalrt_kernel_reset(modalrt_kernel *kernel)
{
  if (!kernel)
    return null_kernel("modalrt_kernel_reset: null kernel");
  kernel->reset();
  return MODALRT_OK;
}

int modalrt_kernel_tick_admittance(modalrt_kernel *kernel, const modalrt_hip_input *inputs, uint32_t count,
                                   modalrt_hip_output *outputs)
{
  return kernel ? kernel->tick(inputs, count, outputs, false) : null_kernel("modalrt_kernel_tick_admittance: null kernel");
}

int modalrt_kernel_tick_impedance(modalrt_kernel *kernel, const modalrt_hip_input *inputs, uint32_t count,
                                  modalrt_hip_output *outputs)
{
  return kernel ? kernel->tick(inputs, count, outputs, true) : null_kernel("modalrt_kernel_tick_impedance: null kernel");
}

int modalrt_kernel_get_haptic_mapping(const modalrt_kernel *kernel, modalrt_haptic_mapping *mapping)
{
  if (!kernel || !mapping)
    return invalid("modalrt_kernel_get_haptic_mapping: null argument");
  kernel->mapping().describe(*mapping, kernel->def);
  return MODALRT_OK;
}

int modalrt_kernel_tick_missing(modalrt_kernel *kernel, uint32_t count, modalrt_hip_output *outputs)
{
  return kernel ? kernel->tick_missing(count, outputs) : null_kernel("modalrt_kernel_tick_missing: null kernel");
}

modalrt_frame_state modalrt_frame_state_identity(void)
{
  modalrt_frame_state f{};
  f.orientation[0] = 1.0;
  return f;
}

int modalrt_kernel_set_frame(modalrt_kernel *kernel, const modalrt_frame_state *frame)
{
  return kernel && frame ? kernel->set_frame(*frame) : null_kernel("modalrt_kernel_set_frame: null argument");
}

int modalrt_kernel_contact_begin(modalrt_kernel *kernel, uint32_t hip, uint32_t vertex)
{
  return kernel ? kernel->contact_begin(hip, vertex) : null_kernel("modalrt_kernel_contact_begin: null kernel");
}

int modalrt_kernel_release_hip(modalrt_kernel *kernel, uint32_t hip)
{
  return kernel ? kernel->release(hip) : null_kernel("modalrt_kernel_release_hip: null kernel");
}

int modalrt_kernel_begin_session(modalrt_kernel *kernel)
{
  if (!kernel)
    return null_kernel("modalrt_kernel_begin_session: null kernel");
  kernel->begin_session();
  return MODALRT_OK;
}

int modalrt_kernel_switch_space(modalrt_kernel *kernel, uint32_t space)
{
  return kernel ? kernel->switch_space(space) : null_kernel("modalrt_kernel_switch_space: null kernel");
}

int modalrt_kernel_settle(modalrt_kernel *kernel, const modalrt_hip_input *inputs, uint32_t count)
{
  return kernel ? kernel->settle(inputs, count) : null_kernel("modalrt_kernel_settle: null kernel");
}

int modalrt_kernel_get_modal_state(const modalrt_kernel *kernel, double *coordinates, double *velocities,
                                   uint32_t capacity, uint32_t *mode_count)
{
  if (!kernel)
    return null_kernel("modalrt_kernel_get_modal_state: null kernel");
  const uint32_t r = kernel->mode_count();
  if (mode_count)
    *mode_count = r;
  if ((coordinates || velocities) && capacity < r)
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_get_modal_state: capacity below the active "
                                                  "space's mode count (*mode_count)");
  if (coordinates)
    std::copy_n(kernel->coordinates(), r, coordinates);
  if (velocities)
    std::copy_n(kernel->velocities(), r, velocities);
  return MODALRT_OK;
}

int modalrt_kernel_get_stats(const modalrt_kernel *kernel, modalrt_kernel_stats *stats)
{
  if (!kernel || !stats)
    return null_kernel("modalrt_kernel_get_stats: null argument");
  *stats = kernel->stats;
  return MODALRT_OK;
}

// ----- display ---------------------------------------------------------------------------------
int modalrt_snapshot_create(const modalrt_kernel *kernel, modalrt_snapshot **snapshot)
{
  if (!kernel || !snapshot)
    return invalid("modalrt_snapshot_create: null argument");
  *snapshot = nullptr;
  return guarded([&] {
    auto s   = new modalrt_snapshot;
    s->basis = &kernel->basis;
    s->owner = kernel;
    s->state.allocate(kernel->basis.max_modes, kernel->def.hip_capacity);
    s->q_f32.assign(kernel->basis.max_modes, 0.0f);
    *snapshot = s;
    return MODALRT_OK;
  });
}

void modalrt_snapshot_destroy(modalrt_snapshot *snapshot) { delete snapshot; }

int modalrt_kernel_snapshot_read(modalrt_kernel *kernel, modalrt_snapshot *snapshot)
{
  if (!kernel || !snapshot)
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_kernel_snapshot_read: null argument");
  // Refused by owner, not by capacities: two kernels of the same basis and capacities have
  // snapshots of the same sizes, and a snapshot read from the wrong one shows the wrong part.
  if (snapshot->owner != kernel)
    return failed(MODALRT_ERROR_INVALID_ARGUMENT,
                  "modalrt_kernel_snapshot_read: the snapshot was created for another kernel (modalrt_snapshot_create "
                  "binds a snapshot to its kernel)");
  return read_snapshot(*kernel, *snapshot);
}

int modalrt_snapshot_get_info(const modalrt_snapshot *snapshot, modalrt_snapshot_info *info)
{
  if (!snapshot || !info)
    return null_kernel("modalrt_snapshot_get_info: null argument");
  modalrt_snapshot_info i{};
  i.tick          = snapshot->state.tick;
  i.time          = snapshot->state.time;
  i.space         = snapshot->state.space;
  i.mode_count    = snapshot->state.mode_count;
  i.contact_count = snapshot->state.contact_count;
  std::copy_n(snapshot->state.frame_position, 3, i.frame_position);
  std::copy_n(snapshot->state.frame_orientation, 4, i.frame_orientation);
  *info = i;
  return MODALRT_OK;
}

const double *modalrt_snapshot_modal_coordinates(const modalrt_snapshot *snapshot)
{
  return snapshot ? snapshot->state.q.data() : nullptr;
}

int modalrt_snapshot_get_contacts(const modalrt_snapshot *snapshot, uint32_t capacity, uint32_t *vertices,
                                  double *corrections, uint32_t *count)
{
  if (!snapshot || !count)
    return failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_snapshot_get_contacts: null snapshot or count");
  if (capacity > 0 && (!vertices || !corrections))
    return failed(MODALRT_ERROR_INVALID_ARGUMENT,
                  "modalrt_snapshot_get_contacts: null vertices or corrections with capacity > 0");
  const modalrt::SnapshotState &s = snapshot->state;
  const std::uint32_t           n = std::min(capacity, s.contact_count);
  std::copy_n(s.contact_vertices.data(), n, vertices);
  std::copy_n(s.contact_corrections.data(), 3 * std::size_t(n), corrections);
  *count = n;
  return MODALRT_OK;
}
} // extern "C"

namespace
{
// The checks of both precisions; reconstruct() itself only guards its range.
  template <typename Out>
  int checked_reconstruct(const char *function, const modalrt_snapshot *snapshot, uint32_t vertex_begin,
                          uint32_t vertex_end, uint32_t flags, Out *out)
  {
    const uint32_t known = MODALRT_DISPLAY_POSITIONS | MODALRT_DISPLAY_WORLD | MODALRT_DISPLAY_NO_CORRECTION;
    if (!snapshot || (flags & ~known) || vertex_begin > vertex_end || vertex_end > snapshot->basis->vertex_count ||
        (!out && vertex_end > vertex_begin))
      return failed(MODALRT_ERROR_INVALID_ARGUMENT, function);
    return reconstruct(*snapshot, vertex_begin, vertex_end, flags, out);
  }
} // namespace

extern "C" {

int modalrt_display_reconstruct(const modalrt_snapshot *snapshot, uint32_t vertex_begin, uint32_t vertex_end,
                                uint32_t flags, float *out)
{
  return checked_reconstruct("modalrt_display_reconstruct: null argument, vertex range beyond the display surface "
                             "or unknown flag",
                             snapshot, vertex_begin, vertex_end, flags, out);
}

int modalrt_display_reconstruct_f64(const modalrt_snapshot *snapshot, uint32_t vertex_begin, uint32_t vertex_end,
                                    uint32_t flags, double *out)
{
  return checked_reconstruct("modalrt_display_reconstruct_f64: null argument, vertex range beyond the display "
                             "surface or unknown flag",
                             snapshot, vertex_begin, vertex_end, flags, out);
}

} // extern "C"
