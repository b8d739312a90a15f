/*
 * modalrt: the real-time kernel of modal-haptics.
 *
 * Loads a `.mrt` basis file (docs/basis-format.md) and runs the haptic loop on it: each tick turns
 * device inputs at the HIPs (haptic interaction points) into the part's response, by the exact
 * zero-order-hold integration of its modal spaces. A display thread reconstructs the whole display
 * surface from a snapshot of the modal state that the tick publishes without locks.
 *
 * Objects and threads
 *   modalrt_basis    immutable after load; may be shared by any number of kernels and threads.
 *   modalrt_kernel   owned by one tick thread (the haptic loop). Every call on it comes from that
 *                    thread, except modalrt_kernel_snapshot_read, which one display thread may call
 *                    concurrently with the ticks (it never blocks them).
 *   modalrt_snapshot owned by the display thread.
 *
 * Guarantees of a tick (modalrt_kernel_tick_admittance / _impedance / _missing): no allocation, no
 * lock, no I/O, no exception, bounded work (capacities are fixed by modalrt_kernel_create).
 *
 * The fail-safe rule (one rule for every rejected or missing input). Every device input is checked;
 * a tick with a non-finite or absurd input is rejected as a whole, and a tick whose input did not
 * arrive (modalrt_kernel_tick_missing) is treated the same way: the state does not move, the
 * outputs are the last safe ones (before any accepted tick: zero force, not in contact) with the
 * MODALRT_HIP_FAIL_SAFE flag, and their force is
 *   - held at the last safe force for fail_safe_hold seconds of consecutive fail-safe ticks
 *     (default 0.5 s: above the scheduling gaps of an ordinary 1 kHz client process on a loaded
 *     machine, measured in docs/reliability.md; a client with real-time priority needs far less), then
 *   - ramped linearly to zero over fail_safe_ramp seconds (default 0.05 s; at least two ticks: never
 *     a step), then zero for as long as no good input comes.
 * Fail-safe tick n of a run (n = 1, 2, ...) scales the last safe force by 1 while n <= H, then by
 * max(0, 1 - (n - H) / R), with H = round(fail_safe_hold / time_step) and
 * R = max(2, round(fail_safe_ramp / time_step)) ticks.
 * In impedance the force is, in addition, at most what a spring plane held at the hand's last
 * accepted position gives it (the fail-safe plane): with F0 the last safe force and s the hand's
 * travel since then along F0 (out of the part), the share 1 - k s / |F0| of F0, clamped to 0 .. 1,
 * k the device's stable stiffness with a haptic scale (device.max_stiffness at the hand), else the
 * coupling's. The hand is at the tick's own input when that input is finite and within
 * workspace_radius (a rejected velocity, a rejected other HIP), else (a missing input, an absurd
 * position) where its last accepted velocity carries it. The share changes by at most
 * force_rate_limit per tick. A withdrawing hand is so given at most |F0|^2 / (2 k), as from a real
 * surface, never the held force over the whole hold; a hand pressing on gets no more than F0; a still
 * hand gets the hold and ramp above exactly. Admittance outputs are held and ramped only.
 * The call returns MODALRT_INPUT_REJECTED; modalrt_kernel_stats counts rejected and missing ticks
 * and the current run of fail-safe ticks. The next accepted tick ends the run.
 *
 * No step of the kernel's own (impedance). A change of force that the kernel makes on its own is
 * rate-limited: the force commanded on the device changes by at most force_rate_limit [N per tick]
 * (default 0.2 N per tick: the device's 10 N in 50 ticks, the slope of the fail-safe ramp at that
 * force) in
 *   - the recovery after a fault: from the first accepted tick after a fail-safe run, the force goes
 *     from the last one commanded (held, ramping or zero) to the coupling's, and the part gets the
 *     limited force (action equals reaction);
 *   - a release (by any rule, modalrt_kernel_release_hip, a HIP absent from the tick, a reset): the
 *     part is free at once, the device's force ramps from the last one commanded to zero.
 * Each such tick's output has MODALRT_HIP_FORCE_RAMPING; the ramp ends at the first tick whose
 * change is within the limit. A new device session is a release (the application releases every HIP
 * when a device restarts or another takes over, as modal-rt serve does). Changes the user makes
 * (pressing deeper, hitting the surface) are rendered as they come, clamped to device.max_force.
 *
 * Frames: the part's body frame is the frame of the basis file. It may move in the world
 * (modalrt_kernel_set_frame); all tick inputs and outputs are in world coordinates.
 *
 * Contact (snap and release rules)
 *   - A HIP that is not in contact looks for the closest vertex of the deformed display surface
 *     within snap_distance of it (a uniform grid over the rest positions finds the candidates; at
 *     most snap_candidate_budget of them, the nearest at rest, are evaluated deformed). It snaps to
 *     that vertex, its active vertex, when its signed distance along the vertex's outward normal
 *     (rest normal, area-weighted) is <= contact_tolerance, i.e. when it touches or is inside.
 *   - The contact is anchored at the active vertex plus the HIP's tangential offset from it at
 *     contact start (zero for modalrt_kernel_contact_begin): a HIP landing between vertices feels
 *     no lateral jerk, and an admittance device is not pulled sideways onto the vertex.
 *   - Release, impedance tick: when the coupling force would pull, i.e. the force on the part along
 *     the outward normal would be attractive (> 0 outward; a surface pushes, it does not stick), or
 *     when the HIP is pulled out of the surface, i.e. its signed distance from the felt contact point
 *     along the outward normal exceeds release_distance, or dragged away from it sideways, i.e. its
 *     distance from the contact point across the normal exceeds release_drag_distance (default
 *     0.01 m, where the default coupling of 1000 N/m reaches the default device's 10 N): a HIP far
 *     from its contact in any direction but into the part is released. Pressing deeper into the part
 *     never releases. With grasp = 1 the first rule is off: the contact holds on and pulls (up to
 *     K x release_distance, about 1 N by default) until one of the others releases it.
 *   - Release, admittance tick: when the force the user applies pulls outward, i.e. its component
 *     along the outward normal exceeds release_force (a contact can push, not pull).
 *   - modalrt_kernel_release_hip releases at once; with auto_release = 0 it is the only release.
 *   - After any release a HIP snaps again only once it has been seen farther than release_distance
 *     outside the surface (or beyond snap_distance from it): no chattering at the surface.
 *   - Switch: at a contact start the active modal space becomes the one whose VOI holds every active
 *     vertex (DISPLAY_REGION), else the global space 0. The state is carried across with the
 *     TRANSFER matrix (q_new = T q_old, same for the velocities); without one it restarts at rest.
 *
 * Sliding contact (contact_mode = MODALRT_CONTACT_PROXY; the snap contact above is the default)
 *   - The contact starts as above, but at the HIP's projection on a triangle around the snapped
 *     vertex: its proxy. The proxy is a point of the deformed display surface (each vertex where the
 *     modes and the contact's static correction put it: rest + B_v q + C F, B_v the vertex's contact
 *     row), held by its triangle and barycentric weights w. Its load point is that blend: row
 *     B = sum_k w_k B_k, residual compliance sum_a sum_b w_a w_b C_ab (C_ab as
 *     modalrt_basis_pair_coupling gives it; a space with neither cross compliance nor a far field:
 *     sum_k w_k C_k), rest position and outward normal blended the same way: force and felt
 *     compliance are continuous as the proxy crosses from one vertex's neighbourhood to the next.
 *   - Impedance ticks: before the step the proxy moves over the surface (across triangles by the
 *     surface's adjacency, at most 4 edges per tick) under Coulomb friction applied to the coupling
 *     force a stuck proxy would give, F = K g + D (v_hip - v_surface), g = x_hip - proxy, split
 *     along the normal of the proxy's triangle (at rest; F_n = -F.n, > 0 when pressing) and across
 *     it (F_t; the plane the proxy walks in, so a press straight in does not slide it off a narrow
 *     face whose blended vertex normals tilt towards its edges): a
 *     sticking proxy stays while |F_t| <= static_friction F_n; then it slides, moved along F_t so
 *     that |F_t| = dynamic_friction F_n (to within 1e-3 of |F_t|), until |F_t| falls within that
 *     cone, when it sticks again.
 *     0 and 0 is frictionless (the tangential force vanishes). At a boundary edge of the surface
 *     the proxy stops. Admittance ticks do not move the proxy.
 *   - Release as the snap contact (outward beyond release_distance, or release_drag_distance across).
 *   - Switch: with MODALRT_SWITCH_AT_CONTACT_START, also when the proxy's nearest vertex enters
 *     another region during the slide (the state carried by TRANSFER as at a contact start).
 *   - modalrt_kernel_contact_begin puts the proxy exactly at the vertex.
 *
 * Validity (a .mrt 1.2 file's validity map, VALIDITY_FORCE; API 3.2)
 *   - Each display vertex of a space may carry the contact force magnitudes F1, F5, F10 [N] up to
 *     which the linear felt compliance stays within 1, 5, 10 % of a geometrically nonlinear full-FE
 *     solve (0: no value there). The kernel compares each contact's force with its validity force at
 *     validity_level (default 5 %) in the active space: a snap contact's vertex's, a proxy's blend of
 *     its triangle's corners that have a value (modalrt_basis_point_validity_force), and sets
 *     MODALRT_HIP_BEYOND_VALIDITY on the HIP's output while |F| exceeds it: F the force commanded
 *     (impedance) or applied to the part (admittance). Where no value exists the flag is never set.
 *   - validity_clamp = 1 (impedance) limits the force's magnitude to the validity force, so the part
 *     is never pressed beyond it; the limit moves at most force_rate_limit per tick (no step of the
 *     kernel's own when the value under a sliding proxy or a switch of space changes it), and rises
 *     towards device.max_force where the map has no value. The flag then says the force before the
 *     clamp is beyond. Fail-safe ticks keep the flag while the force held is beyond the last value.
 *
 * Units are SI everywhere: m, N, kg, s, rad. Every struct field names its unit.
 */
#ifndef MODALRT_MODALRT_H
#define MODALRT_MODALRT_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32) && defined(MODALRT_SHARED)
#  if defined(MODALRT_BUILDING)
#    define MODALRT_API __declspec(dllexport)
#  else
#    define MODALRT_API __declspec(dllimport)
#  endif
#elif defined(__GNUC__) && defined(MODALRT_BUILDING)
#  define MODALRT_API __attribute__((visibility("default")))
#else
#  define MODALRT_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Versioning. MODALRT_VERSION_MAJOR changes when a struct's layout, a default or the meaning of a
 * call changes, so that an application must be rebuilt against the new header (and should read what
 * changed); MODALRT_VERSION_MINOR changes when something is only added (a function, a flag bit, a
 * status) and an application built against an older minor of the same major works unchanged. Within
 * a major version no field is added to a struct: a `reserved` field (which must be 0) may be given a
 * meaning whose value 0 keeps the old behaviour. An application checks at start-up that
 * modalrt_version() / 1000 == MODALRT_VERSION_MAJOR.
 * 3.0: modalrt_kernel_def gained force_rate_limit and grasp (rate-limited force changes of the
 * kernel's own, release of an impedance contact that would pull), MODALRT_HIP_FORCE_RAMPING,
 * modalrt_kernel_begin_session; and contact_mode, static_friction and dynamic_friction (the sliding
 * proxy contact, MODALRT_CONTACT_PROXY), modalrt_hip_output's proxy_triangle and proxy_weights,
 * modalrt_kernel_stats's passivity_energy, MODALRT_HIP_SLIDING.
 * 3.1: modalrt_basis_point_compliance (the static compliance where a proxy sits),
 * modalrt_basis_felt_stiffness (the felt-stiffness map), modalrt_basis_pair_is_exact; reads .mrt 1.1 (the cross compliance
 * between neighbouring candidates only, as compressed rows).
 * 3.2: reads .mrt 1.2 (the validity map, VALIDITY_FORCE); modalrt_basis_validity_forces and
 * modalrt_basis_point_validity_force; MODALRT_HIP_BEYOND_VALIDITY; modalrt_kernel_def's former
 * `reserved` is validity_level and its former `reserved2` is validity_clamp (both 0 by default: the
 * 5 % level, no clamp; a 3.1 application that left them 0 gets the flag and nothing else).
 * 3.3: reads .mrt 1.3 (the far field, FAR_COMPLIANCE: two candidates without a stored cross block are
 * coupled by Z_a Z_b^T instead of the modes alone); modalrt_basis_pair_coupling and the
 * MODALRT_COUPLING_* values; modalrt_space_info's former `reserved` is far_rank (0: no far field).
 * 3.4: modalrt_kernel_def's former `reserved_proxy` is proxy_row_memory (0 by default: a sliding
 * kernel makes the contact rows of the vertices that are not candidates at creation, within 256 MiB;
 * what it renders is the same to round-off (a pair block summed with its rows in the other order),
 * only no tick builds a row any more where they fit);
 * MODALRT_PROXY_ROWS_IN_TICKS.
 * 4.0: fields added at the end of modalrt_device_def (rate, workspace, kind), modalrt_kernel_def
 * (haptic_scale, workspace_scale, workspace_origin, coupling_multiple, passivity_control),
 * modalrt_kernel_stats (the passivity observer and controller at the hand); the sampled-passivity check is Colgate & Schenkel's
 * b > K T / 2 + |B| (the former K T / 2 < b + D let a coupling through that it refuses), and a
 * kernel whose device does not meet it needs passivity_control = 1 (the default); an impedance
 * contact's force now starts at force_rate_limit (no step at a contact start or a switch);
 * modalrt_device_profile_find / _name (named specs of real devices), MODALRT_HIP_BEYOND_RANGE,
 * MODALRT_HIP_PASSIVITY_DAMPED, modalrt_kernel_get_haptic_mapping. */
#define MODALRT_VERSION_MAJOR 4
#define MODALRT_VERSION_MINOR 0

/* Highest major and minor version of the .mrt format this library reads. */
#define MODALRT_BASIS_FORMAT_MAJOR 1
#define MODALRT_BASIS_FORMAT_MINOR 3

/* Marks "no vertex" / "no space" in outputs. */
#define MODALRT_NONE 0xFFFFFFFFu

/* ------------------------------------------------------------------------------------------------
 * Status codes: 0 is success, a positive code is a warning whose outputs are valid, a negative code
 * is an error. Every call that returns a negative status (tick calls included) sets the message that
 * modalrt_last_error_message() returns; a successful call leaves it as it was. Each function below
 * lists the statuses it can return ("Returns: ..."); it returns no other.
 * --------------------------------------------------------------------------------------------- */
enum
{
  MODALRT_OK                     = 0,
  MODALRT_INPUT_REJECTED         = 1,  /* tick only: input rejected or missing; fail-safe outputs */
  MODALRT_ERROR_INVALID_ARGUMENT = -1, /* null pointer, index out of range, bad definition field */
  MODALRT_ERROR_IO               = -2, /* the file could not be opened or read */
  MODALRT_ERROR_FORMAT           = -3, /* magic, version, sizes, layout or indices of a basis file */
  MODALRT_ERROR_CHECKSUM         = -4, /* a CRC-32 of a basis file does not match */
  MODALRT_ERROR_VALUE            = -5, /* a number is not finite or out of its range */
  MODALRT_ERROR_OUT_OF_MEMORY    = -6,
  MODALRT_ERROR_DEVICE_LIMIT     = -7, /* the virtual coupling breaks the device spec or passivity */
  MODALRT_ERROR_STATE            = -8, /* the call is not allowed in the current state */
  MODALRT_ERROR_VERIFY_FAILED    = -9  /* the self-check exceeded its tolerance */
};

/* Why inputs were rejected (bits of modalrt_kernel_stats.last_reject_reasons). */
enum
{
  MODALRT_REJECT_NOT_FINITE     = 1u << 0, /* NaN or infinity */
  MODALRT_REJECT_FORCE          = 1u << 1, /* |force| > max_input_force */
  MODALRT_REJECT_POSITION       = 1u << 2, /* |position| > workspace_radius */
  MODALRT_REJECT_VELOCITY       = 1u << 3, /* |velocity| > max_input_velocity */
  MODALRT_REJECT_FRAME          = 1u << 4, /* the frame state is not finite or absurd */
  MODALRT_REJECT_HIP_COUNT      = 1u << 5, /* more HIPs than the kernel's capacity */
  MODALRT_REJECT_MISSING        = 1u << 6  /* no input this tick (modalrt_kernel_tick_missing) */
};

/* Message of the last call that failed (negative status) in this thread ("" if none). Never NULL;
 * valid until the next failing call in this thread (a fixed buffer, never freed). */
MODALRT_API const char *modalrt_last_error_message(void);

/* Constant name of a status code ("MODALRT_ERROR_CHECKSUM", ...). */
MODALRT_API const char *modalrt_status_name(int status);

/* Library version, MODALRT_VERSION_MAJOR * 1000 + MODALRT_VERSION_MINOR. */
MODALRT_API uint32_t modalrt_version(void);

/* Sets flush-to-zero and denormals-are-zero in the calling thread on x86 (SSE MXCSR); no effect
 * elsewhere. Optional: the integrator already flushes decaying states explicitly, so denormals
 * never reach it; call it in the tick thread to cover the application's own arithmetic too.
 * Returns 1 when the flags were set, 0 on platforms without them. */
MODALRT_API int modalrt_thread_enable_flush_to_zero(void);

/* Optional allocator hooks. Every array of a basis, a kernel and a snapshot, and the objects
 * themselves, are allocated through `allocate(bytes, alignment, user)` and returned through
 * `deallocate(pointer, bytes, alignment, user)` (the same bytes and alignment). Set them at load time:
 * before the first basis is loaded, or once every basis, kernel and snapshot is destroyed. NULL (or
 * both function pointers NULL) restores the default (operator new and delete). `allocate` returns
 * NULL on failure (the call then returns MODALRT_ERROR_OUT_OF_MEMORY). Small strings (file names,
 * messages) and the loader's temporary buffers use the standard allocator. Ticks allocate nothing.
 * Not thread-safe against calls that create or destroy objects. */
typedef struct modalrt_allocator
{
  void *(*allocate)(size_t bytes, size_t alignment, void *user);
  void (*deallocate)(void *pointer, size_t bytes, size_t alignment, void *user);
  void *user; /* passed to both */
} modalrt_allocator;

/* Returns: OK, ERROR_INVALID_ARGUMENT (only one of the two functions set), ERROR_STATE (a basis,
 * kernel or snapshot exists). */
MODALRT_API int modalrt_set_allocator(const modalrt_allocator *allocator);

/* ------------------------------------------------------------------------------------------------
 * Basis: one loaded .mrt file
 * --------------------------------------------------------------------------------------------- */
typedef struct modalrt_basis modalrt_basis;

/* Reads and checks a .mrt file: magic, version, sizes, every CRC-32, finite numbers, index ranges,
 * patch weights summing to 1, numbers within their ranges (docs/basis-format.md). On failure *basis
 * is NULL and the message names the file and the section. Memory: about the file's size plus the
 * derived arrays (normals, grid); nothing grows faster than the file.
 * Returns: OK, ERROR_INVALID_ARGUMENT, ERROR_IO, ERROR_FORMAT, ERROR_CHECKSUM, ERROR_VALUE,
 * ERROR_OUT_OF_MEMORY. */
MODALRT_API int  modalrt_basis_load(const char *path, modalrt_basis **basis);
/* Same from bytes in memory (copied; `bytes` may be freed after the call). Returns: as
 * modalrt_basis_load but never ERROR_IO. */
MODALRT_API int  modalrt_basis_load_memory(const void *bytes, size_t size, modalrt_basis **basis);
MODALRT_API void modalrt_basis_destroy(modalrt_basis *basis);

typedef struct modalrt_basis_info
{
  uint32_t version_major;          /* [-] format version of the file */
  uint32_t version_minor;          /* [-] */
  uint64_t file_bytes;             /* [bytes] */
  uint32_t section_count;          /* [-] entries in the section table */
  uint32_t space_count;            /* [-] modal spaces, space 0 is the global space */
  uint32_t display_vertex_count;   /* [-] */
  uint32_t display_triangle_count; /* [-] */
  uint32_t max_modes;              /* [-] max over spaces of r */
  uint32_t max_patch_size;         /* [-] max display vertices in one contact patch */
  uint32_t mode_scalar_bytes;      /* [bytes] 4: float32 display modes, 8: float64 */
  uint32_t reserved;               /* 0 */
  double   patch_radius;           /* [m] contact patch radius rho */
  double   mass;                   /* [kg] */
  double   centre_of_mass[3];      /* [m] body frame */
  double   inertia[9];             /* [kg m^2] about the centre of mass, row-major */
  double   bounds_min[3];          /* [m] bounding box of the display vertices at rest */
  double   bounds_max[3];          /* [m] */
} modalrt_basis_info;

/* Returns: OK, ERROR_INVALID_ARGUMENT (null argument). */
MODALRT_API int modalrt_basis_get_info(const modalrt_basis *basis, modalrt_basis_info *info);

typedef struct modalrt_space_info
{
  char     name[64];          /* UTF-8, NUL-terminated (truncated if longer) */
  uint32_t mode_count;        /* [-] r */
  uint32_t candidate_count;   /* [-] contact candidates with a stored static correction */
  uint32_t validation_count;  /* [-] full-FE validation cases */
  uint32_t cross_count;       /* [-] candidates with cross compliance rows (0 or candidate_count): each with
                                 its neighbours closer than the precompute's cross compliance radius */
  uint32_t has_participation; /* 1 if PARTICIPATION is stored (frame acceleration drives the modes) */
  uint32_t far_rank;          /* [-] rank k of the far field (FAR_COMPLIANCE, .mrt 1.3), 0 without one
                                 (API 3.3; before: reserved, 0) */
  double   lowest_frequency;  /* [Hz] */
  double   highest_frequency; /* [Hz] */
} modalrt_space_info;

/* Returns: OK, ERROR_INVALID_ARGUMENT (null argument, space out of range). */
MODALRT_API int modalrt_basis_get_space_info(const modalrt_basis *basis, uint32_t space, modalrt_space_info *info);

/* Arrays owned by the basis, valid until modalrt_basis_destroy; NULL if out of range. */
MODALRT_API const double   *modalrt_basis_eigenvalues(const modalrt_basis *basis, uint32_t space);     /* r [rad^2/s^2] */
MODALRT_API const double   *modalrt_basis_damping_ratios(const modalrt_basis *basis, uint32_t space);  /* r [-] */
MODALRT_API const uint32_t *modalrt_basis_candidates(const modalrt_basis *basis, uint32_t space);      /* nc vertices */
MODALRT_API const double   *modalrt_basis_display_vertices(const modalrt_basis *basis);  /* 3 nv [m] rest, body frame */
MODALRT_API const uint32_t *modalrt_basis_display_triangles(const modalrt_basis *basis); /* 3 nt vertex indices */
MODALRT_API const uint32_t *modalrt_basis_display_regions(const modalrt_basis *basis);   /* nv space per vertex */
MODALRT_API const double   *modalrt_basis_display_normals(const modalrt_basis *basis);   /* 3 nv unit outward [-] */
/* The felt-stiffness map of a space: at every display vertex the stiffness a HIP pressing straight in
 * along the normal would feel there with the full FE model, 1 / (n^T W^T K^-1 W n) [N/m] (0 where the
 * space did not compute it); NULL if the file has no map (a .mrt 1.0) or space is out of range. */
MODALRT_API const double   *modalrt_basis_felt_stiffness(const modalrt_basis *basis, uint32_t space);
/* The validity map of a space (.mrt 1.2, section VALIDITY_FORCE): at display vertex v, entries 3 v + 0,
 * 1, 2 are the contact force magnitudes F1, F5, F10 [N] up to which the linear felt compliance stays
 * within 1 %, 5 %, 10 % of a geometrically nonlinear full-FE solve; 0 where the space has no value,
 * 1e30 where the departure is not reached (up to the precompute's force limit); positive entries are
 * non-decreasing within a vertex (the loader refuses a file that breaks this). NULL if the file has no
 * map (a .mrt 1.0 or 1.1, or a space the analysis left out) or space is out of range. */
MODALRT_API const double   *modalrt_basis_validity_forces(const modalrt_basis *basis, uint32_t space);
/* The validity force [N] at a point of display triangle `triangle` with barycentric weights `weights`
 * (>= 0, sum 1; a vertex: that corner's weight 1) for departure level `level_percent` (1, 5 or 10):
 * sum_k w_k F_k / sum_k w_k over the corners k whose F_k at that level is > 0 (a corner without a
 * value is left out, so the value is continuous as a proxy slides, and equals the stored one at a
 * vertex). *force is 0 where no corner with a weight has a value (or the space has no map): no
 * validity force there, never beyond it. What the kernel compares a contact's force with
 * (MODALRT_HIP_BEYOND_VALIDITY). No allocation.
 * Returns: OK, ERROR_INVALID_ARGUMENT (null argument, space or triangle out of range, a level other
 * than 1, 5, 10, weights negative, non-finite or not summing to 1 within 1e-9). */
MODALRT_API int modalrt_basis_point_validity_force(const modalrt_basis *basis, uint32_t space, uint32_t triangle,
                                                   const double weights[3], uint32_t level_percent, double *force);
/* 1 when two HIPs at display vertices a and b of a space feel the full FE answer together: both are
 * candidates and their residual cross compliance is stored (neighbours closer than the precompute's
 * cross compliance radius, or sharing a display triangle), or a == b is a candidate; else 0 (also
 * for a bad argument, and for a pair the far field couples: modalrt_basis_pair_coupling's 2). */
MODALRT_API int modalrt_basis_pair_is_exact(const modalrt_basis *basis, uint32_t space, uint32_t a, uint32_t b);
/* How the kernel couples two contacts beyond the modes (modalrt_basis_pair_coupling). */
enum
{
  MODALRT_COUPLING_NONE  = 0, /* no residual coupling: the modes alone (a vertex is not a candidate, or the
                                 pair is not stored and the space has no far field) */
  MODALRT_COUPLING_EXACT = 1, /* the stored residual (a candidate's own block at a == b, or the stored cross
                                 block): with the modes, the full FE answer (modalrt_basis_pair_is_exact) */
  MODALRT_COUPLING_FAR   = 2  /* the far field's approximation Z_a Z_b^T (FAR_COMPLIANCE, .mrt 1.3) of a pair
                                 without a stored block; the precompute's report.json states its measured
                                 error (spaces[].far_field) */
};
/* The residual coupling C_ab [m/N] (3x3, row-major, body frame) that the kernel adds to the modes'
 * B_a Lambda^-1 B_b^T between contacts at display vertices vertex_a and vertex_b of a space (the
 * displacement at a is u_a = sum_b (B_a Lambda^-1 B_b^T + C_ab) F_b), and where it comes from: the
 * one rule the kernel follows. Both vertices must be candidates; then the candidate's own
 * CANDIDATE_COMPLIANCE at a == b, the stored cross block of a stored pair (both exact), else
 * Z_a Z_b^T when the space has a far field, else none. C is filled for EXACT and FAR, zeroed for NONE;
 * it may be NULL. modalrt_space_info's far_rank gives the rank k. No allocation.
 * Returns: MODALRT_COUPLING_NONE, _EXACT or _FAR; ERROR_INVALID_ARGUMENT (null basis, space or vertex
 * out of range). */
MODALRT_API int modalrt_basis_pair_coupling(const modalrt_basis *basis, uint32_t space, uint32_t vertex_a,
                                            uint32_t vertex_b, double C[9]);
/* Static compliance G [m/N] (3x3, row-major, body frame) of a contact at display vertex `vertex` in
 * space `space`: the settled felt displacement of the active vertex (patch average) is u_c = G F for
 * a constant force F on it, alone on the part. At a candidate of the space G = B_v Lambda^-1 B_v^T +
 * C_v, which is exactly the full static FE compliance W_v^T K^-1 W_v of its patch, and *full_fe is
 * set to 1; elsewhere only the modal part B_v Lambda^-1 B_v^T (B_v from the vertex-lumped patch, as
 * the kernel builds it) is available and *full_fe is 0. The stiffness felt along a unit direction n
 * is 1 / (n^T G n). `full_fe` may be NULL. No allocation.
 * Returns: OK, ERROR_INVALID_ARGUMENT (null argument, space or vertex out of range), ERROR_VALUE (the
 * space has a mode with omega = 0: a part that is not held has no static compliance). */
MODALRT_API int modalrt_basis_contact_compliance(const modalrt_basis *basis, uint32_t space, uint32_t vertex,
                                                 double compliance[9], uint32_t *full_fe);
/* Static compliance G [m/N] (3x3, row-major, body frame) of a load at a point of display triangle
 * `triangle`, spread over its three corners' contacts with the barycentric weights `weights` (>= 0,
 * sum 1): where a proxy contact sits (modalrt_hip_output's proxy_triangle and proxy_weights). G =
 * B Lambda^-1 B^T + C with B = sum_k w_k B_k (each corner's row as in modalrt_basis_contact_compliance)
 * and C = sum_a sum_b w_a w_b C_ab over corners at candidates, C_ab as modalrt_basis_pair_coupling
 * gives it (in a space with neither CROSS_COMPLIANCE nor a far field: sum_k w_k C_k): the residual the
 * kernel gives a proxy there. *full_fe is 1 when it is the full static FE compliance of the blended
 * load: every corner with a weight is a candidate, and every pair of them is coupled exactly (one
 * corner holds the whole weight, or their cross blocks are stored). `full_fe` may be NULL. No allocation.
 * Returns: OK, ERROR_INVALID_ARGUMENT (null argument, space or triangle out of range, weights
 * negative, non-finite or not summing to 1 within 1e-9), ERROR_VALUE (a mode with omega = 0). */
MODALRT_API int modalrt_basis_point_compliance(const modalrt_basis *basis, uint32_t space, uint32_t triangle,
                                               const double weights[3], double compliance[9], uint32_t *full_fe);
/* 1 if the file holds TRANSFER from space `from` into space `to`, else 0. */
MODALRT_API int modalrt_basis_has_transfer(const modalrt_basis *basis, uint32_t to, uint32_t from);

typedef struct modalrt_section_info
{
  char     name[24];     /* "DISPLAY_MODES", ..., "UNKNOWN" for kinds of a newer minor version */
  uint32_t kind;         /* [-] section kind of the format */
  uint32_t space;        /* [-] MODALRT_NONE for scene-wide sections */
  uint32_t source_space; /* [-] TRANSFER: the space the state comes from; else MODALRT_NONE */
  uint32_t scalar_type;  /* [-] 1 u32, 2 f32, 3 f64, 4 u8 */
  uint32_t reserved;     /* 0 */
  uint64_t offset;       /* [bytes] from the start of the file */
  uint64_t count;        /* [-] scalars */
  uint64_t bytes;        /* [bytes] */
} modalrt_section_info;

/* Returns: OK, ERROR_INVALID_ARGUMENT (null argument, index out of range). */
MODALRT_API int modalrt_basis_get_section(const modalrt_basis *basis, uint32_t index, modalrt_section_info *info);

/* ------------------------------------------------------------------------------------------------
 * Self-check: the stored full-FE validation cases against the kernel's static response
 * --------------------------------------------------------------------------------------------- */
typedef struct modalrt_verify_case
{
  uint32_t space;          /* [-] */
  uint32_t vertex;         /* [-] display vertex of the unit force */
  uint32_t direction;      /* [-] 0, 1, 2 = x, y, z */
  uint32_t is_candidate;   /* 1 if the vertex has a static correction in this space */
  double   kernel[3];      /* [m/N] u_c the kernel settles to under a unit force */
  double   reference[3];   /* [m/N] VALIDATION_RESPONSE (full static FE) */
  double   relative_error; /* [-] |kernel - reference| / |reference| */
} modalrt_verify_case;

typedef struct modalrt_verify_report
{
  uint32_t case_count;         /* [-] over all spaces */
  uint32_t worst_case;         /* [-] index (over all spaces, in file order) of the largest error */
  double   max_relative_error; /* [-] */
  double   tolerance;          /* [-] 1e-8 with float64 modes, 1e-5 with float32 */
} modalrt_verify_report;

/* Drives one kernel per space with each stored unit force (contact at the case's vertex, modal state
 * settled to its exact static equilibrium, then one admittance tick) and compares u_c to the
 * reference. A space with rigid-body modes (lambda = 0, a free-floating part) runs in the frame that
 * follows the part's rigid acceleration under the force (inertia relief). `index` counts cases over
 * all spaces in file order.
 * Returns: OK, ERROR_INVALID_ARGUMENT (null argument, index out of range), ERROR_STATE (a free-floating
 * space's case away from a candidate, or singular rigid-body participation), ERROR_OUT_OF_MEMORY. */
MODALRT_API int modalrt_basis_verify_case(const modalrt_basis *basis, uint32_t index, modalrt_verify_case *result);
/* All cases. Returns: OK, ERROR_VERIFY_FAILED (the max error exceeds the tolerance; the report is
 * filled), ERROR_INVALID_ARGUMENT, ERROR_STATE (as modalrt_basis_verify_case), ERROR_OUT_OF_MEMORY. */
MODALRT_API int modalrt_basis_verify(const modalrt_basis *basis, modalrt_verify_report *report);

/* ------------------------------------------------------------------------------------------------
 * Kernel definition
 * --------------------------------------------------------------------------------------------- */

/* What the device can render (after CHAI3D's cHapticDeviceInfo). Defaults of
 * modalrt_device_default_def() in brackets. */
typedef struct modalrt_device_def
{
  double max_force;        /* [N] largest force the device renders; impedance outputs are clamped to it [10] */
  double max_stiffness;    /* [N/m] largest stiffness the device renders stably at the tick rate [3000] */
  double max_damping;      /* [N s/m] largest damping the device renders stably [10] */
  double physical_damping; /* [N s/m] the device's own viscous damping b (0 if unknown) [0] */
  double   rate;           /* [Hz] rate at which max_stiffness and max_damping hold (API 4.0) [1000] */
  double   workspace[3];   /* [m] extent of the device's workspace along its x, y, z (0: unknown) (API 4.0) [0] */
  uint32_t kind;           /* MODALRT_DEVICE_IMPEDANCE or _ADMITTANCE (API 4.0) [IMPEDANCE] */
  uint32_t reserved;       /* 0 */
} modalrt_device_def;

enum
{
  MODALRT_DEVICE_IMPEDANCE  = 0, /* position in, force out (Phantom, Touch, Falcon, omega, sigma, lambda) */
  MODALRT_DEVICE_ADMITTANCE = 1  /* force in, position out (HapticMaster-like): renders any stiffness */
};

/* Returns the defaults above; never fails. */
MODALRT_API modalrt_device_def modalrt_device_default_def(void);

/* Device profiles (API 4.0): the published spec of a class of device, by name: "touch", "omni",
 * "desktop", "falcon", "omega.x", "sigma.7", "lambda.7" (impedance; CHAI3D 3.3.0's device classes,
 * realtime/README.md gives each figure's source) and "admittance" (a generic admittance device of the
 * HapticMaster's class). Fills *spec. Returns: OK, ERROR_INVALID_ARGUMENT (null argument, unknown name:
 * the message lists the names). */
MODALRT_API int         modalrt_device_profile_find(const char *name, modalrt_device_def *spec);
/* The name of profile `index` (0, 1, ...), NULL past the last one. */
MODALRT_API const char *modalrt_device_profile_name(uint32_t index);

enum
{
  MODALRT_CONTACT_SNAP  = 0, /* the HIP's contact stays at its active vertex (default) */
  MODALRT_CONTACT_PROXY = 1  /* a proxy slides over the deformed surface with friction (see the top) */
};

/* modalrt_kernel_def.proxy_row_memory: make no contact row at creation (every row of a vertex that is
 * not a candidate is built in the ticks, ahead of the proxy). */
#define MODALRT_PROXY_ROWS_IN_TICKS 0xFFFFFFFFu

enum
{
  MODALRT_SWITCH_AT_CONTACT_START = 0, /* change space when a contact starts (default) */
  MODALRT_SWITCH_NEVER            = 1  /* stay in the space set by the application */
};

/* The kernel's definition. Defaults of modalrt_kernel_default_def() in brackets; modalrt_kernel_create
 * checks every field (MODALRT_ERROR_INVALID_ARGUMENT or _DEVICE_LIMIT and a message naming it). */
typedef struct modalrt_kernel_def
{
  double   time_step;             /* [s] tick period T, 1e-6 .. 1 [1e-3] */
  uint32_t hip_capacity;          /* [-] HIPs the kernel handles, 1 .. 16 [4] */
  uint32_t initial_space;         /* [-] active space before any contact [0] */
  modalrt_device_def device;      /* the device's limits [modalrt_device_default_def()] */
  double   coupling_stiffness;    /* [N/m] impedance virtual coupling K, <= device.max_stiffness [1000] */
  double   coupling_damping;      /* [N s/m] impedance virtual coupling D, <= device.max_damping [2] */
  double   snap_distance;         /* [m] a HIP snaps to a vertex only within this distance, > 0 [0.01] */
  double   contact_tolerance;     /* [m] signed distance along the normal at or below which a HIP touches [0] */
  double   release_distance;      /* [m] impedance release and re-arm distance outside the surface, >= 0 [1e-3] */
  double   release_force;         /* [N] admittance release: outward pulling force above this, >= 0 [0.05] */
  double   max_input_force;       /* [N] a larger input force is absurd: the tick is rejected [1000] */
  double   workspace_radius;      /* [m] a HIP farther than this from the world origin is rejected [10] */
  double   max_input_velocity;    /* [m/s] a faster HIP is rejected [100] */
  double   max_frame_acceleration; /* [m/s^2, rad/s^2] a larger frame acceleration is rejected [1e4] */
  uint32_t snap_candidate_budget; /* [-] vertices evaluated deformed per snap query, 1 .. 256 [16] */
  uint32_t switch_rule;           /* MODALRT_SWITCH_AT_CONTACT_START or MODALRT_SWITCH_NEVER [AT_CONTACT_START] */
  uint32_t carry_state_on_switch; /* 1: q_new = T q_old at a switch; 0: restart at rest [1] */
  uint32_t use_static_correction; /* 1: add the residual compliance C_v F at candidates [1] */
  uint32_t auto_release;          /* 1: apply the release rules; 0: only modalrt_kernel_release_hip [1] */
  uint32_t snapshot_interval;     /* [ticks] publish a display snapshot every this many ticks, >= 1 [1] */
  uint32_t enable_profile;        /* 1: time every tick (two clock reads) into modalrt_kernel_stats [0] */
  uint32_t validity_level;        /* [%] departure level of MODALRT_HIP_BEYOND_VALIDITY and validity_clamp: 1, 5
                                     or 10 (the validity map's F1, F5, F10); 0 means 5 [0: 5 %, below the ~8 %
                                     stiffness difference a person tells apart] (API 3.2; before: reserved, 0) */
  double   release_drag_distance; /* [m] impedance release: HIP this far from its contact across the normal, > 0 [0.01] */
  double   fail_safe_hold;        /* [s] fail-safe: the last safe force is held this long, 0 .. 10 [0.5] */
  double   fail_safe_ramp;        /* [s] fail-safe: then ramped to zero over this time (at least 2 ticks), > 0 .. 10 [0.05] */
  double   force_rate_limit;      /* [N per tick] impedance: largest change of the commanded force per tick in a
                                     change the kernel makes on its own (recovery after a fault, release), > 0 ..
                                     device.max_force [0.2] */
  uint32_t grasp;                 /* impedance: 0 releases a contact whose force would pull; 1 lets it pull (a
                                     grasp) until release_distance or release_drag_distance releases it [0] */
  uint32_t validity_clamp;        /* impedance: 1 limits the magnitude of the force rendered at a contact to its
                                     validity force at validity_level (where the map has a value; the limit
                                     follows the contact at most force_rate_limit per tick, so it never steps);
                                     0: no such limit [0] (API 3.2; before: reserved2, 0) */
  uint32_t contact_mode;          /* MODALRT_CONTACT_SNAP or MODALRT_CONTACT_PROXY [SNAP] */
  uint32_t proxy_row_memory;      /* [MiB] proxy: memory for the contact rows (3 r doubles) of the display vertices
                                     that are not candidates and the pair blocks of vertices sharing a triangle,
                                     made at creation so that no tick builds them; spaces in order, a space that
                                     would pass the limit builds its rows ahead of the proxy in the ticks; 0 means
                                     256; MODALRT_PROXY_ROWS_IN_TICKS: none at creation [0: 256 MiB]
                                     (API 3.4; before: reserved_proxy, 0) */
  double   static_friction;       /* [-] proxy: Coulomb static coefficient mu_s, 0 .. 10, >= dynamic_friction [0.3] */
  double   dynamic_friction;      /* [-] proxy: Coulomb dynamic coefficient mu_d, 0 .. static_friction [0.2] */
  /* The haptic mapping (API 4.0; realtime/README.md, "What the hand feels"). Inputs and outputs of the
   * ticks are in the device's units: a HIP's part position is workspace_origin + workspace_scale x its
   * device position. With haptic_scale s > 0 (impedance) the hand feels s x the part's stiffness: the
   * coupling on the part is coupling_multiple x device.max_stiffness / s (so its series share at the
   * stiffest part the band holds is 1 / (1 + coupling_multiple)), coupling_stiffness is not used and
   * coupling_damping is the damping at the hand; the force commanded is s / workspace_scale x the force
   * on the part, device.max_force and the passivity controller apply at the hand, and the force along
   * the contact normal is at most device.max_stiffness x the hand's travel into the surface (beyond the
   * band: a wall at the device's stable stiffness, MODALRT_HIP_BEYOND_RANGE). s = 0: no scale, the
   * coupling_stiffness spring in series with the part (the hand feels both). */
  double   haptic_scale;          /* [-] s, 0 (off) or > 0 [0] */
  double   workspace_scale;       /* [m of part per m of device] sigma, > 0; 0 means 1 [0] */
  double   workspace_origin[3];   /* [m] world point of the part where the device's origin maps [0] */
  double   coupling_multiple;     /* [-] with haptic_scale: the part's coupling over the band's stiffest part,
                                     >= 10; 0 means 200 (series share <= 0.5 %) [0] */
  uint32_t passivity_control;     /* impedance: 1 runs the passivity controller at the hand (Hannaford & Ryu
                                     2002: per HIP the observer of the energy the hand put in over its contact,
                                     and when it is negative a damping that dissipates it, at most
                                     device.max_damping); required when the device does not meet Colgate &
                                     Schenkel's b > K T / 2 + |B|; 0: off [1] */
  uint32_t reserved_hand;         /* 0 */
} modalrt_kernel_def;

/* Returns the defaults above; never fails. */
MODALRT_API modalrt_kernel_def modalrt_kernel_default_def(void);

/* ------------------------------------------------------------------------------------------------
 * Kernel: the haptic loop
 * --------------------------------------------------------------------------------------------- */
typedef struct modalrt_kernel modalrt_kernel;

/* Allocates every buffer the ticks will need. Checks the coupling against the device: K <= max
 * stiffness, D <= max damping, and (impedance devices) Colgate & Schenkel's sampled-passivity condition
 * b > K T / 2 + |B|, b the device's physical_damping, K the largest stiffness the hand is rendered
 * (coupling_stiffness; with haptic_scale, device.max_stiffness) and B the virtual damping at the hand
 * (coupling_damping): a kernel whose device fails it is refused (naming b, K, T, B) unless
 * passivity_control = 1. The basis must outlive the kernel. Returns: OK, ERROR_INVALID_ARGUMENT (null argument, a field out of its range),
 * ERROR_DEVICE_LIMIT (coupling beyond the device or not passive), ERROR_OUT_OF_MEMORY. */
MODALRT_API int  modalrt_kernel_create(const modalrt_basis *basis, const modalrt_kernel_def *def, modalrt_kernel **kernel);
MODALRT_API void modalrt_kernel_destroy(modalrt_kernel *kernel);

/* Modal state to rest, every HIP released, active space = initial_space, the fail-safe run ended,
 * counters kept. Returns: OK, ERROR_INVALID_ARGUMENT (null kernel). */
MODALRT_API int modalrt_kernel_reset(modalrt_kernel *kernel);

typedef struct modalrt_hip_input
{
  double position[3]; /* [m] world position of the HIP (the device's end effector) */
  double velocity[3]; /* [m/s] world velocity of the HIP (measured by the device) */
  double force[3];    /* [N] admittance: world force the user applies to the part; impedance: unused */
} modalrt_hip_input;

enum
{
  MODALRT_HIP_CONTACT_STARTED = 1u << 0, /* snapped during this tick */
  MODALRT_HIP_RELEASED        = 1u << 1, /* released during this tick */
  MODALRT_HIP_FORCE_CLAMPED   = 1u << 2, /* impedance force limited to device.max_force */
  MODALRT_HIP_CORRECTED       = 1u << 3, /* the active vertex is a candidate: static correction applied */
  MODALRT_HIP_SPACE_SWITCHED  = 1u << 4, /* the active space changed during this tick */
  MODALRT_HIP_FAIL_SAFE       = 1u << 5, /* input rejected or missing: the last safe output, force held
                                            or ramping down (the fail-safe rule above) */
  MODALRT_HIP_FORCE_RAMPING   = 1u << 6, /* impedance: the force is rate-limited to force_rate_limit this
                                            tick (recovery after a fault, or a release ramping to zero) */
  MODALRT_HIP_SLIDING         = 1u << 7, /* proxy contact: the proxy is sliding (dynamic friction) */
  MODALRT_HIP_BEYOND_RANGE    = 1u << 9,  /* haptic_scale: the force at the hand was limited to
                                            device.max_stiffness x the hand's travel (a part stiffer
                                            than the band, or a fast press's transient) */
  MODALRT_HIP_PASSIVITY_DAMPED = 1u << 10, /* the passivity controller added damping this tick */
  MODALRT_HIP_BEYOND_VALIDITY = 1u << 8  /* in contact, the contact force is beyond its validity force:
                                            |F| > the validity map's force at validity_level where the
                                            contact is (a proxy: its corners' blend, as
                                            modalrt_basis_point_validity_force), F the force commanded
                                            (impedance; with validity_clamp the force before that clamp)
                                            or applied (admittance). Never set where the map has no
                                            value, nor with a file without a map (.mrt 1.0, 1.1) */
};

typedef struct modalrt_hip_output
{
  double   position[3];   /* [m] world position of the active vertex plus the contact's anchor offset
                            (what an admittance device tracks); a proxy contact: the proxy's position on
                            the deformed surface; the HIP's input position when not in contact */
  double   velocity[3];   /* [m/s] world velocity of the active vertex (modal part; the static correction
                            is quasi-static and adds no velocity); the input velocity when not in contact */
  double   force[3];      /* [N] impedance: world force to command on the device; admittance: the force
                            applied to the part (the input force in contact, else 0) */
  uint32_t in_contact;    /* 1 while the HIP has an active vertex */
  uint32_t active_vertex; /* display vertex, MODALRT_NONE when not in contact */
  uint32_t space;         /* active modal space of the kernel */
  uint32_t flags;         /* MODALRT_HIP_* bits */
  uint32_t proxy_triangle;   /* proxy contact: display triangle of the proxy, else MODALRT_NONE */
  uint32_t reserved;         /* 0 */
  double   proxy_weights[3]; /* [-] proxy contact: barycentric weights of the triangle's three vertices (in
                                its order in the basis), >= 0, sum 1; active_vertex is the heaviest; else 0 */
} modalrt_hip_output;

/* Admittance step (the original method, for admittance devices): forces at the HIPs in, positions
 * and velocities of the active vertices out: u_c = B_v q (+ C_v F + cross terms at candidates).
 * `count` HIPs (<= hip_capacity) in `inputs` and `outputs`; HIPs from `count` on are released.
 * Returns: OK, INPUT_REJECTED (the fail-safe rule; reasons in modalrt_kernel_stats),
 * ERROR_INVALID_ARGUMENT (null kernel, or null inputs/outputs with count > 0). */
MODALRT_API int modalrt_kernel_tick_admittance(modalrt_kernel *kernel, const modalrt_hip_input *inputs, uint32_t count,
                                               modalrt_hip_output *outputs);

/* Impedance step (Phantom/Touch-type devices): HIP positions and velocities in, forces out through
 * the virtual coupling F = K (x_hip - x_v) + D (v_hip - v_v), solved together with the modal step so
 * that a stiff coupling on a compliant part stays stable, and clamped to device.max_force.
 * Returns: as modalrt_kernel_tick_admittance. */
MODALRT_API int modalrt_kernel_tick_impedance(modalrt_kernel *kernel, const modalrt_hip_input *inputs, uint32_t count,
                                              modalrt_hip_output *outputs);

/* Pose and motion of the part's body frame in the world. The frame's acceleration drives the modes
 * through PARTICIPATION (f -= Gamma a); centrifugal and Coriolis loads on the modes are neglected.
 * Gravity g is rendered by adding -g to linear_acceleration. */
typedef struct modalrt_frame_state
{
  double position[3];             /* [m] world position of the body frame's origin */
  double orientation[4];          /* [-] unit quaternion w, x, y, z: body to world */
  double linear_velocity[3];      /* [m/s] world velocity of the origin */
  double angular_velocity[3];     /* [rad/s] world */
  double linear_acceleration[3];  /* [m/s^2] world acceleration of the origin */
  double angular_acceleration[3]; /* [rad/s^2] world */
} modalrt_frame_state;

/* A frame at rest at the world origin, identity orientation; never fails. */
MODALRT_API modalrt_frame_state modalrt_frame_state_identity(void);

/* A tick whose input did not arrive (a device packet late or lost): the fail-safe rule, as for a
 * rejected input (reason MODALRT_REJECT_MISSING, counted in modalrt_kernel_stats.missing_ticks).
 * Writes `count` outputs. Returns: INPUT_REJECTED, ERROR_INVALID_ARGUMENT (null kernel, null outputs
 * with count > 0, count > hip_capacity). */
MODALRT_API int modalrt_kernel_tick_missing(modalrt_kernel *kernel, uint32_t count, modalrt_hip_output *outputs);

/* Applies from the next tick. A non-finite or absurd frame is refused (counted in rejected_frames,
 * old frame kept). Returns: OK, ERROR_VALUE (frame refused), ERROR_INVALID_ARGUMENT (null argument). */
MODALRT_API int modalrt_kernel_set_frame(modalrt_kernel *kernel, const modalrt_frame_state *frame);

/* Snaps HIP `hip` to display vertex `vertex` now (as a detected contact would, switch included).
 * Returns: OK, ERROR_INVALID_ARGUMENT (null kernel, hip or vertex out of range). */
MODALRT_API int modalrt_kernel_contact_begin(modalrt_kernel *kernel, uint32_t hip, uint32_t vertex);
/* Releases HIP `hip` now (no effect if not in contact). Returns: OK, ERROR_INVALID_ARGUMENT (null
 * kernel, hip out of range). */
MODALRT_API int modalrt_kernel_release_hip(modalrt_kernel *kernel, uint32_t hip);
/* A new device session (a device driver restarted, or another device took over, or the device left):
 * every HIP is released as by modalrt_kernel_release_hip (its force ramping to zero at
 * force_rate_limit) and snaps again only once it has been seen outside the surface (beyond
 * release_distance, or beyond snap_distance from it), so no contact carries over from one session to
 * the next. Returns: OK, ERROR_INVALID_ARGUMENT (null kernel). */
MODALRT_API int modalrt_kernel_begin_session(modalrt_kernel *kernel);
/* Makes `space` the active space now, carrying the state as a switch does. Returns: OK,
 * ERROR_INVALID_ARGUMENT (null kernel, space out of range). */
MODALRT_API int modalrt_kernel_switch_space(modalrt_kernel *kernel, uint32_t space);
/* Puts the modal state at the exact static equilibrium under the given admittance forces (and the
 * frame's acceleration): q = Lambda^-1 f, velocities 0. Modes with omega = 0 keep their state.
 * Returns: OK, ERROR_VALUE (an input is not finite or absurd), ERROR_INVALID_ARGUMENT (null kernel,
 * null inputs with count > 0). */
MODALRT_API int modalrt_kernel_settle(modalrt_kernel *kernel, const modalrt_hip_input *inputs, uint32_t count);

/* Copies the modal state of the active space: coordinates [m sqrt(kg)] and velocities; either may
 * be NULL. Returns: OK, ERROR_INVALID_ARGUMENT (null kernel, capacity below the mode count). */
MODALRT_API int modalrt_kernel_get_modal_state(const modalrt_kernel *kernel, double *coordinates, double *velocities,
                                               uint32_t capacity, uint32_t *mode_count);

typedef struct modalrt_kernel_stats
{
  uint64_t tick_count;          /* [-] ticks run, rejected ones included */
  uint64_t rejected_ticks;      /* [-] ticks whose inputs were rejected */
  uint64_t rejected_frames;     /* [-] frame states rejected by modalrt_kernel_set_frame */
  uint64_t clamped_forces;      /* [-] impedance forces limited to device.max_force */
  uint64_t switch_count;        /* [-] changes of active space */
  uint64_t missing_ticks;       /* [-] modalrt_kernel_tick_missing calls */
  uint64_t fail_safe_ticks;     /* [-] ticks under the fail-safe rule (rejected + missing) */
  uint64_t fail_safe_run;       /* [-] consecutive fail-safe ticks up to the last tick (0 after an accepted one) */
  uint64_t dropout_ticks;       /* [-] fail-safe ticks past fail_safe_hold with a non-zero last safe force: the
                                   force the device got was below it (ramping or zero) */
  uint32_t last_reject_reasons; /* MODALRT_REJECT_* bits of the last rejected tick */
  uint32_t active_space;        /* [-] */
  double   time;                /* [s] simulated time */
  double   last_tick_seconds;   /* [s] duration of the last tick (enable_profile) */
  double   max_tick_seconds;    /* [s] worst tick duration (enable_profile) */
  double   max_switch_jump;     /* [m] largest displacement jump of an active vertex at a switch */
  double   passivity_energy;    /* [J] passivity observer (Hannaford & Ryu 2002) of the impedance ticks: the
                                   work the hand has done on the kernel, sum over HIPs and accepted ticks of
                                   -F_(n-1) . (x_n - x_(n-1)) (F the force commanded on the device and held
                                   over the period, x the HIP's world position). The kernel gave the hand
                                   energy overall when it is negative; passive: it never falls below a small
                                   negative number. A fail-safe tick leaves the next period unobserved.
                                   With a haptic mapping: in the part's units. */
  /* At the hand (API 4.0): the device's own units, whatever the mapping. */
  double   hand_passivity_energy;   /* [J] the observer above at the hand, summed over HIPs */
  double   min_hip_passivity_energy; /* [J] the lowest per-HIP observer over its contact (the window: from
                                        contact start until the force is back to zero after release) */
  double   passivity_damping_energy; /* [J] energy the passivity controller dissipated */
  double   max_passivity_damping;   /* [N s/m] the largest damping it added */
  uint64_t passivity_damped_ticks;  /* [-] HIP ticks in which it acted */
  uint64_t beyond_range_ticks;      /* [-] HIP ticks flagged MODALRT_HIP_BEYOND_RANGE */
} modalrt_kernel_stats;

/* Returns: OK, ERROR_INVALID_ARGUMENT (null argument). */
MODALRT_API int modalrt_kernel_get_stats(const modalrt_kernel *kernel, modalrt_kernel_stats *stats);

/* The kernel's haptic mapping as it runs it (API 4.0). */
typedef struct modalrt_haptic_mapping
{
  double haptic_scale;        /* [-] s: stiffness at the hand / stiffness of the part (1 without a scale) */
  double workspace_scale;     /* [m of part per m of device] sigma */
  double workspace_origin[3]; /* [m] */
  double force_scale;         /* [-] force commanded / force on the part, s / sigma */
  double part_coupling_stiffness; /* [N/m] the coupling spring on the part (in the part's units) */
  double part_coupling_damping;   /* [N s/m] its damper */
  double band_top_stiffness;  /* [N/m] the stiffest part rendered to scale (device.max_stiffness / s;
                                 0 without a scale) */
  double series_share;        /* [-] the coupling's share of the compliance at band_top_stiffness,
                                 band_top / (band_top + part_coupling_stiffness) (0 without a scale) */
} modalrt_haptic_mapping;

/* Returns: OK, ERROR_INVALID_ARGUMENT (null argument). */
MODALRT_API int modalrt_kernel_get_haptic_mapping(const modalrt_kernel *kernel, modalrt_haptic_mapping *mapping);

/* ------------------------------------------------------------------------------------------------
 * Display: snapshots of the modal state and the reconstruction of the display surface
 * --------------------------------------------------------------------------------------------- */
typedef struct modalrt_snapshot modalrt_snapshot;

/* A snapshot sized for the kernel's capacities (allocates; call it outside the loops). Returns: OK,
 * ERROR_INVALID_ARGUMENT (null argument), ERROR_OUT_OF_MEMORY. */
MODALRT_API int  modalrt_snapshot_create(const modalrt_kernel *kernel, modalrt_snapshot **snapshot);
MODALRT_API void modalrt_snapshot_destroy(modalrt_snapshot *snapshot);

/* Copies the latest published state into `snapshot` (triple buffer: wait-free for both sides, one
 * reader thread at a time). A snapshot reads only the kernel it was created for. Returns 1 if the
 * state is newer than the previous read, 0 if not, or ERROR_INVALID_ARGUMENT (null argument, a
 * snapshot created for another kernel, even one of the same basis and capacities). */
MODALRT_API int modalrt_kernel_snapshot_read(modalrt_kernel *kernel, modalrt_snapshot *snapshot);

typedef struct modalrt_snapshot_info
{
  uint64_t tick;             /* [-] tick that published it */
  double   time;             /* [s] simulated time */
  uint32_t space;            /* [-] active space */
  uint32_t mode_count;       /* [-] r of that space */
  uint32_t contact_count;    /* [-] HIPs in contact */
  uint32_t reserved;         /* 0 */
  double   frame_position[3];    /* [m] */
  double   frame_orientation[4]; /* [-] w, x, y, z */
} modalrt_snapshot_info;

/* Returns: OK, ERROR_INVALID_ARGUMENT (null argument). */
MODALRT_API int modalrt_snapshot_get_info(const modalrt_snapshot *snapshot, modalrt_snapshot_info *info);
/* The modal coordinates of the snapshot (mode_count values) [m sqrt(kg)]. */
MODALRT_API const double *modalrt_snapshot_modal_coordinates(const modalrt_snapshot *snapshot);
/* The snapshot's contacts at candidates, for a display that reconstructs elsewhere (a GPU): the
 * active vertex of each of the first contact_count contacts and its static correction C F [m] (body
 * frame), which modalrt_display_reconstruct spreads over the patch with (1 - (d/rho)^2)^2. Copies at
 * most `capacity` contacts; *count is the number copied. Read only, no allocation.
 * Returns: OK, ERROR_INVALID_ARGUMENT (null snapshot or count, null vertices or corrections with
 * capacity > 0). */
MODALRT_API int modalrt_snapshot_get_contacts(const modalrt_snapshot *snapshot, uint32_t capacity, uint32_t *vertices,
                                              double *corrections, uint32_t *count);

enum
{
  MODALRT_DISPLAY_DISPLACEMENTS = 0,      /* output u [m] in the body frame (default) */
  MODALRT_DISPLAY_POSITIONS     = 1u << 0, /* output rest position + u [m] */
  MODALRT_DISPLAY_WORLD         = 1u << 1, /* with POSITIONS: apply the frame pose */
  MODALRT_DISPLAY_NO_CORRECTION = 1u << 2  /* leave out the static correction near the contacts */
};

/* u = Phi q over display vertices [vertex_begin, vertex_end) plus, near each contact at a candidate,
 * its static correction C F spread over the contact patch with the profile (1 - (d/rho)^2)^2 (so the
 * active vertex is drawn where it is felt). Writes 3 floats per vertex to `out` (out[0] is vertex
 * vertex_begin). Callable from any thread; splitting the range splits the work. Returns: OK,
 * ERROR_INVALID_ARGUMENT (null argument, range not within 0 .. vertex count, unknown flag). */
MODALRT_API int modalrt_display_reconstruct(const modalrt_snapshot *snapshot, uint32_t vertex_begin, uint32_t vertex_end,
                                            uint32_t flags, float *out);
/* Same with double output. */
MODALRT_API int modalrt_display_reconstruct_f64(const modalrt_snapshot *snapshot, uint32_t vertex_begin,
                                                uint32_t vertex_end, uint32_t flags, double *out);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* MODALRT_MODALRT_H */
