#include "run_outputs.h"

#include "design_pair.h"

#include "allocation_counter.h"
#include "stiffness_map.h"
#include "vertex_info.h"

#include <mrt/atomic_file.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>

#include <nlohmann/json.hpp>

#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char **environ;

namespace modalrt_tool
{
  namespace
  {
    std::string format(const char *pattern, double value)
    {
      char text[64];
      std::snprintf(text, sizeof text, pattern, value);
      return text;
    }

    // A vertex or triangle index for a CSV field or stats.json: -1 for MODALRT_NONE.
    long long index_or_minus_one(std::uint32_t index) { return index == MODALRT_NONE ? -1ll : (long long)index; }

    void rotate(const double q[4], const double v[3], double out[3])
    {
      // v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z) of the unit quaternion.
      const double w = q[0], u[3] = {q[1], q[2], q[3]};
      const double t[3] = {2.0 * (u[1] * v[2] - u[2] * v[1]), 2.0 * (u[2] * v[0] - u[0] * v[2]),
                           2.0 * (u[0] * v[1] - u[1] * v[0])};
      out[0] = v[0] + w * t[0] + (u[1] * t[2] - u[2] * t[1]);
      out[1] = v[1] + w * t[1] + (u[2] * t[0] - u[0] * t[2]);
      out[2] = v[2] + w * t[2] + (u[0] * t[1] - u[1] * t[0]);
    }
  } // namespace

  bool write_file_atomically(const std::string &path, const std::string &text, std::string &error)
  {
    return mrt::write_text_atomically(path, text, error);
  }


  namespace
  {
    // The machine's byte order, in which the frames' values and byte counts are written.
    const char *vtk_byte_order()
    {
      const std::uint16_t one = 1;
      unsigned char       first;
      std::memcpy(&first, &one, 1);
      return first == 1 ? "LittleEndian" : "BigEndian";
    }

    // One array of the appended block: its byte count (UInt64, VTK's header_type) then its bytes.
    template <typename T>
    void append_block(std::string &block, const T *values, std::size_t count)
    {
      const std::uint64_t bytes = count * sizeof(T);
      block.append(reinterpret_cast<const char *>(&bytes), sizeof bytes);
      block.append(reinterpret_cast<const char *>(values), bytes);
    }

    // A DataArray of the appended block ("" name: the Points' array, which has none).
    std::string appended_array(const char *type, const std::string &name, unsigned components, std::uint64_t offset)
    {
      const std::string named = name.empty() ? "" : " Name=\"" + name + "\"";
      return std::string("        <DataArray type=\"") + type + "\"" + named + " NumberOfComponents=\"" +
             std::to_string(components) + "\" format=\"appended\" offset=\"" + std::to_string(offset) + "\"/>\n";
    }
  } // namespace

  VtuFrameWriter::VtuFrameWriter(const modalrt_basis *basis) : rest_(modalrt_basis_display_vertices(basis))
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    vertex_count_   = info.display_vertex_count;
    triangle_count_ = info.display_triangle_count;
    const std::uint32_t       *triangles = modalrt_basis_display_triangles(basis);
    std::vector<std::uint32_t> offsets(triangle_count_);
    for (std::uint32_t t = 0; t < triangle_count_; ++t)
      offsets[t] = 3 * (t + 1);
    const std::vector<std::uint8_t> types(triangle_count_, 5); // VTK_TRIANGLE
    append_block(cells_and_regions_, triangles, 3 * std::size_t(triangle_count_));
    append_block(cells_and_regions_, offsets.data(), offsets.size());
    append_block(cells_and_regions_, types.data(), types.size());
    append_block(cells_and_regions_, modalrt_basis_display_regions(basis), vertex_count_);

    // Every frame has the same arrays of the same sizes: the XML after its comment line is fixed.
    // Each array's offset: where its byte count starts, counted from after the '_'.
    std::uint64_t offset = 0;
    const auto    next   = [&offset](std::uint64_t bytes) {
      const std::uint64_t at = offset;
      offset += sizeof(std::uint64_t) + bytes;
      return at;
    };
    const std::uint64_t n = vertex_count_, m = triangle_count_;
    const std::uint64_t points_at = next(12 * n), connectivity_at = next(12 * m), offsets_at = next(4 * m);
    const std::uint64_t types_at = next(m), regions_at = next(4 * n), displacement_at = next(12 * n);
    char                piece[128];
    std::snprintf(piece, sizeof piece, "    <Piece NumberOfPoints=\"%u\" NumberOfCells=\"%u\">\n", vertex_count_,
                  triangle_count_);
    xml_ = std::string("<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"") + vtk_byte_order() +
           "\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n" + piece + "      <Points>\n" +
           appended_array("Float32", "", 3, points_at) + "      </Points>\n      <Cells>\n" +
           appended_array("UInt32", "connectivity", 1, connectivity_at) + appended_array("UInt32", "offsets", 1, offsets_at) +
           appended_array("UInt8", "types", 1, types_at) + "      </Cells>\n      <PointData Vectors=\"displacement\">\n" +
           appended_array("UInt32", "region", 1, regions_at) +
           appended_array("Float32", "displacement", 3, displacement_at) +
           "      </PointData>\n    </Piece>\n  </UnstructuredGrid>\n  <AppendedData encoding=\"raw\">\n_";
  }

  bool VtuFrameWriter::write(const std::string &path, const modalrt_snapshot_info &info, const float *displacements,
                             std::string &error) const
  {
    std::vector<float> points(3 * std::size_t(vertex_count_)), moved(3 * std::size_t(vertex_count_));
    for (std::uint32_t v = 0; v < vertex_count_; ++v)
      {
        double x[3], w[3];
        rotate(info.frame_orientation, rest_ + 3 * std::size_t(v), x);
        const double u[3] = {displacements[3 * v], displacements[3 * v + 1], displacements[3 * v + 2]};
        rotate(info.frame_orientation, u, w);
        for (int d = 0; d < 3; ++d)
          {
            points[3 * v + d] = float(x[d] + info.frame_position[d]);
            moved[3 * v + d]  = float(w[d]);
          }
      }
    char comment[128];
    std::snprintf(comment, sizeof comment, "<?xml version=\"1.0\"?>\n<!-- modal-rt run: t = %.9g s, space %u -->\n",
                  info.time, info.space);
    std::string text = comment + xml_;
    text.reserve(text.size() + cells_and_regions_.size() + 24 * std::size_t(vertex_count_) + 64);
    append_block(text, points.data(), points.size());
    text += cells_and_regions_;
    append_block(text, moved.data(), moved.size());
    text += "\n  </AppendedData>\n</VTKFile>\n";
    return write_file_atomically(path, text, error);
  }

  bool write_pvd(const std::string &path, const std::vector<FrameRecord> &frames, std::string &error)
  {
    std::string text = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n";
    for (const FrameRecord &f : frames)
      text += "    <DataSet timestep=\"" + format("%.9g", f.time) + "\" file=\"" + f.file + "\"/>\n";
    text += "  </Collection>\n</VTKFile>\n";
    return write_file_atomically(path, text, error);
  }

  namespace
  {
    double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

    // What one trace row of one HIP in contact felt along the normal of its load point (a proxy's point
    // on its triangle, else the active vertex): the force pushing into the part and the friction
    // (tangential) force [N], the static stiffness there 1 / (n^T G n) and the felt one, the normal force
    // over the normal displacement of the load point into the part [N/m]. NaN where there is none.
    struct FeltAlongNormal
    {
      double normal_force = std::nan(""), tangential_force = std::nan("");
      double static_stiffness = std::nan(""), felt_stiffness = std::nan("");
    };

    FeltAlongNormal felt_along_normal(const modalrt_basis *basis, const TraceSample &s, double force_sign)
    {
      FeltAlongNormal out;
      if (!s.in_contact)
        return out;
      double rest[3], n[3], compliance = std::nan("");
      bool   full_fe = false;
      int    status  = MODALRT_OK;
      if (s.proxy_triangle != MODALRT_NONE)
        status = point_normal_compliance(basis, s.space, s.proxy_triangle, s.proxy_weights, rest, n, compliance, full_fe);
      else
        {
          std::copy_n(modalrt_basis_display_vertices(basis) + 3 * std::size_t(s.active_vertex), 3, rest);
          std::copy_n(modalrt_basis_display_normals(basis) + 3 * std::size_t(s.active_vertex), 3, n);
          status = normal_compliance(basis, s.space, s.active_vertex, compliance, full_fe);
        }
      const double along = dot3(s.force, n);
      double       tangential[3], moved[3];
      for (int d = 0; d < 3; ++d)
        tangential[d] = s.force[d] - along * n[d], moved[d] = s.contact[d] - s.frame[d] - rest[d];
      out.normal_force     = force_sign * along;
      out.tangential_force = std::sqrt(dot3(tangential, tangential));
      out.felt_stiffness   = out.normal_force / -dot3(moved, n);
      if (status == MODALRT_OK)
        out.static_stiffness = 1.0 / compliance;
      return out;
    }
  } // namespace

  double trace_validity_force(const modalrt_basis *basis, const TraceSample &s, std::uint32_t level)
  {
    const double force =
      s.in_contact ? contact_validity_force(basis, s.space, s.active_vertex, s.proxy_triangle, s.proxy_weights, level) : 0.0;
    return force > 0.0 ? force : std::nan("");
  }

  bool write_trace(const std::string &path, const HapticResult &result, std::uint32_t hip_count,
                   const modalrt_basis *basis_a, bool impedance, std::uint32_t validity_level, std::string &error,
                   const modalrt_basis *design_b)
  {
    std::string text = "# modal-rt run trace: time [s]; per HIP h: device position [m], contact point [m] "
                       "(the felt point in contact: a proxy's position on the deformed surface; else the device), "
                       "force [N], in contact, active vertex (-1: none), active space, the output's MODALRT_HIP_* "
                       "flags (32 FAIL_SAFE, 64 FORCE_RAMPING, 128 SLIDING, ...), the proxy's triangle (-1: none) "
                       "and barycentric weights, then along the outward normal n of the load point (the proxy's "
                       "point, else the active vertex): fn the force pushing into the part [N], ft the friction "
                       "(tangential) force [N], static_stiffness 1 / (n^T G n) of the basis there [N/m], "
                       "felt_stiffness fn / the load point's displacement into the part [N/m] (nan: not in "
                       "contact), beyond 1 when the output is flagged MODALRT_HIP_BEYOND_VALIDITY (256: |F| above "
                       "validity_force), validity_force the validity map's force there at the kernel's level [N] "
                       "(nan: no value); then the origin of the part's frame [m]; with two designs felt in turn, "
                       "design (A or B, the one in front: vertex, space and stiffness are of its basis) and "
                       "design_b_share (B's share of the output: 0 < share < 1 during a fade)\ntime";
    for (std::uint32_t h = 0; h < hip_count; ++h)
      for (const char *column : {"x", "y", "z", "cx", "cy", "cz", "fx", "fy", "fz", "contact", "vertex", "space", "flags",
                                 "triangle", "w0", "w1", "w2", "fn", "ft", "static_stiffness", "felt_stiffness",
                                 "beyond", "validity_force"})
        text += ",hip" + std::to_string(h) + "_" + column;
    text += design_b ? ",frame_x,frame_y,frame_z,design,design_b_share\n" : ",frame_x,frame_y,frame_z\n";
    const std::uint64_t rows = result.trace.size() / std::max<std::uint32_t>(hip_count, 1);
    char                field[64];
    for (std::uint64_t r = 0; r < rows; ++r)
      {
        text += format("%.9g", result.trace[r * hip_count].time);
        for (std::uint32_t h = 0; h < hip_count; ++h)
          {
            const TraceSample   &s     = result.trace[r * hip_count + h];
            const modalrt_basis *basis = design_b && s.design == 1 ? design_b : basis_a;
            for (const double *v : {s.hip, s.contact, s.force})
              for (int d = 0; d < 3; ++d)
                text += "," + format("%.9g", v[d]);
            std::snprintf(field, sizeof field, ",%u,%lld,%u,%u,%lld", s.in_contact, index_or_minus_one(s.active_vertex),
                          s.space, s.flags, index_or_minus_one(s.proxy_triangle));
            text += field;
            const FeltAlongNormal felt = felt_along_normal(basis, s, impedance ? 1.0 : -1.0);
            for (double value : {s.proxy_weights[0], s.proxy_weights[1], s.proxy_weights[2], felt.normal_force,
                                 felt.tangential_force, felt.static_stiffness, felt.felt_stiffness})
              text += "," + format("%.9g", value);
            text += (s.flags & MODALRT_HIP_BEYOND_VALIDITY) ? ",1," : ",0,";
            text += format("%.9g", trace_validity_force(basis, s, validity_level));
          }
        const double *frame = result.trace[r * hip_count].frame;
        text += "," + format("%.9g", frame[0]) + "," + format("%.9g", frame[1]) + "," + format("%.9g", frame[2]);
        if (design_b)
          text += std::string(",") + "AB"[result.trace[r * hip_count].design] + "," +
                  format("%.9g", result.trace[r * hip_count].design_share);
        text += '\n';
      }
    return write_file_atomically(path, text, error);
  }

  namespace
  {
    // Space names go into a CSV field and a plot title: no separators, no control characters.
    std::string csv_safe(const char *text)
    {
      std::string out = text;
      for (char &c : out)
        if (c == ',' || c == '"' || static_cast<unsigned char>(c) < 0x20)
          c = '_';
      return out;
    }

    // true when HIP `hip` is sliding at time t (between a slide's first and last sliding tick).
    bool sliding_at(const std::vector<Slide> &slides, std::uint32_t hip, double t)
    {
      for (const Slide &s : slides)
        if (s.hip == hip && t >= s.start && t <= s.end)
          return true;
      return false;
    }

    // The contact periods of one HIP: runs of trace rows in contact at the same active vertex (a
    // release and a new snap between two rows start a new press). Rows within a slide belong to the
    // slide (slides.csv), not to a press: a proxy moving over the part is not pressing one vertex.
    void collect_presses(const HapticResult &result, std::uint32_t hips, std::uint32_t hip, std::vector<Press> &out)
    {
      const std::size_t rows = result.trace.size() / hips;
      bool              open = false;
      for (std::size_t r = 0; r < rows; ++r)
        {
          const TraceSample &s       = result.trace[r * hips + hip];
          const bool         pressed = s.in_contact && !sliding_at(result.slides, hip, s.time);
          if (open && (!pressed || s.active_vertex != out.back().vertex))
            open = false;
          if (pressed && !open)
            {
              Press p;
              p.hip       = hip;
              p.vertex    = s.active_vertex;
              p.first_row = r;
              out.push_back(p);
              open = true;
            }
          if (open)
            out.back().last_row = r;
        }
    }

    // The static compliance of the press's contact along its normal, in the space of its last row: at
    // the vertex, or for a proxy contact at the proxy's point of that row (a press does not slide:
    // the proxy stays there), with that point's rest position and blended normal.
    void static_reference(Press &p, const TraceSample &last, const modalrt_basis *basis)
    {
      modalrt_space_info info;
      modalrt_basis_get_space_info(basis, p.space, &info);
      p.space_name = csv_safe(info.name);
      int status   = MODALRT_OK;
      if (last.proxy_triangle != MODALRT_NONE)
        status = point_normal_compliance(basis, p.space, last.proxy_triangle, last.proxy_weights, p.rest, p.normal,
                                         p.compliance, p.full_fe);
      else
        {
          std::copy_n(modalrt_basis_display_normals(basis) + 3 * std::size_t(p.vertex), 3, p.normal);
          std::copy_n(modalrt_basis_display_vertices(basis) + 3 * std::size_t(p.vertex), 3, p.rest);
          status = normal_compliance(basis, p.space, p.vertex, p.compliance, p.full_fe);
        }
      if (status != MODALRT_OK)
        p.compliance = std::nan(""); // a space with a free mode: no static stiffness to compare with
    }

    // Normal force pushing into the part [N] and normal displacement into it [m] of one trace row.
    void normal_response(const Press &p, const TraceSample &s, double force_sign, double &force, double &displacement)
    {
      // The anchor offset is tangential: it drops out along the normal.
      const double moved[3] = {s.contact[0] - s.frame[0] - p.rest[0], s.contact[1] - s.frame[1] - p.rest[1],
                               s.contact[2] - s.frame[2] - p.rest[2]};
      force        = force_sign * dot3(s.force, p.normal);
      displacement = -dot3(moved, p.normal);
    }

    // A row whose force the kernel held or ramped on its own (a fault's fail-safe plateau, the
    // rate-limited recovery or release): not a force the hand pushed with, so never the felt one.
    bool kernel_held(const TraceSample &s) { return (s.flags & (MODALRT_HIP_FAIL_SAFE | MODALRT_HIP_FORCE_RAMPING)) != 0; }

    // The felt stiffness at the end of the push: at the last local maximum of the normal force that
    // reaches half the press's largest force, i.e. the end of a hold before unloading. (The largest
    // force itself is often the transient of the hand landing on the surface, not a settled state.)
    // Rows the kernel held (kernel_held) are left out of both: under a jittery client a held
    // plateau above the real maximum would be picked. A press held throughout keeps its last row.
    void felt_response(Press &p, const HapticResult &result, std::uint32_t hips, double force_sign, double force_scale)
    {
      std::vector<double>      force, displacement;
      std::vector<std::size_t> rows; // the press's rows the hand pushed in
      for (std::size_t r = p.first_row; r <= p.last_row; ++r)
        {
          std::uint32_t contacts = 0;
          for (std::uint32_t h = 0; h < hips; ++h)
            contacts += result.trace[r * hips + h].in_contact;
          p.max_contacts = std::max(p.max_contacts, contacts);
          const TraceSample &s = result.trace[r * hips + p.hip];
          if (kernel_held(s) && !(r == p.last_row && rows.empty()))
            continue;
          rows.push_back(r);
          force.push_back(0.0);
          displacement.push_back(0.0);
          normal_response(p, s, force_sign, force.back(), displacement.back());
        }
      const std::size_t n       = rows.size();
      const double      largest = *std::max_element(force.begin(), force.end());
      std::size_t       end     = n - 1;
      while (end > 0 && !(force[end] >= 0.5 * largest && (end + 1 == n || force[end + 1] <= force[end]) &&
                          force[end - 1] <= force[end]))
        --end;
      p.felt_time         = result.trace[rows[end] * hips].time;
      p.felt_force        = force[end];
      p.felt_displacement = displacement[end];
      const bool pushed   = p.felt_force > 0.0 && p.felt_displacement > 0.0;
      p.felt_stiffness    = pushed ? p.felt_force / force_scale / p.felt_displacement : std::nan("");
      const TraceSample &s = result.trace[rows[end] * hips + p.hip];
      const double moved[3] = {s.hip[0] - s.frame[0] - p.rest[0], s.hip[1] - s.frame[1] - p.rest[1],
                               s.hip[2] - s.frame[2] - p.rest[2]};
      p.hand_travel    = -dot3(moved, p.normal);
      p.hand_stiffness = p.felt_force > 0.0 && p.hand_travel > 0.0 ? p.felt_force / p.hand_travel : std::nan("");
    }

    // The static answer to every HIP in contact at the press's felt time (deliverable: multi-contact
    // presses compared with full FE). A reference kernel (admittance, no auto release) snaps each
    // HIP to its vertex, is settled to the exact static equilibrium under the forces the part received
    // in that trace row, and one tick gives each contact's displacement u_c = B q + C F + the cross
    // terms: with every contact a candidate of the space and every pair's cross compliance stored
    // (modalrt_basis_pair_is_exact), that is the full
    // static FE answer W_a^T K^-1 sum_b W_b F_b; otherwise the modal part (and the corrections that exist).
    // The press against its validity force: the largest |F|, the value at its point (its last row's
    // contact), and the first row the kernel flagged MODALRT_HIP_BEYOND_VALIDITY (at the trace's rate).
    void validity_of(Press &p, const HapticResult &result, std::uint32_t hips, const modalrt_basis *basis,
                     std::uint32_t level)
    {
      for (std::size_t r = p.first_row; r <= p.last_row; ++r)
        {
          const TraceSample &s    = result.trace[r * hips + p.hip];
          const double       size = std::sqrt(dot3(s.force, s.force));
          p.max_force             = std::max(p.max_force, size);
          if ((s.flags & MODALRT_HIP_BEYOND_VALIDITY) && !p.beyond)
            p.beyond = true, p.beyond_time = s.time, p.beyond_force = size;
        }
      p.validity_force = trace_validity_force(basis, result.trace[p.last_row * hips + p.hip], level);
    }

    // Why the multi-contact reference at `vertices` is not the full-FE answer ("" when it is): the
    // contacts away from the space's candidates (no static correction), else the first pair the space
    // does not couple exactly (modalrt_basis_pair_coupling): not at all (no cross compliance, or a
    // pair not stored and no far field), or by the far field's approximation (far_rank is then set to
    // its rank: the reference is the kernel's answer with it, whose error the precompute measured).
    std::string multi_contact_note(const modalrt_basis *basis, std::uint32_t space_index,
                                   const std::vector<std::uint32_t> &vertices, std::uint32_t &far_rank)
    {
      modalrt_space_info space{};
      modalrt_basis_get_space_info(basis, space_index, &space);
      const std::string name = csv_safe(space.name);
      std::string       away;
      for (std::uint32_t v : vertices)
        {
          double        G[9];
          std::uint32_t full = 0;
          if (modalrt_basis_contact_compliance(basis, space_index, v, G, &full) != MODALRT_OK || !full)
            away += " " + std::to_string(v);
        }
      if (!away.empty())
        return "not a candidate of '" + name + "': vertex" + away;
      std::string far;
      for (std::size_t i = 0; i < vertices.size(); ++i)
        for (std::size_t j = i + 1; j < vertices.size(); ++j)
          {
            const std::uint32_t va = vertices[i], vb = vertices[j];
            const std::string   pair = std::to_string(va) + " and " + std::to_string(vb);
            const int coupling = modalrt_basis_pair_coupling(basis, space_index, va, vb, nullptr);
            if (coupling == MODALRT_COUPLING_FAR && far.empty())
              far = "far-field coupling (rank " + std::to_string(space.far_rank) + ") between vertices " + pair +
                    ": the precompute's report.json states its measured error (spaces[].far_field)";
            else if (coupling != MODALRT_COUPLING_EXACT && coupling != MODALRT_COUPLING_FAR)
              return space.cross_count == 0 && space.far_rank == 0
                       ? "space '" + name + "' stores no cross compliance"
                       : "vertices " + pair + " are farther apart than the cross compliance radius of '" + name + "'";
          }
      far_rank = far.empty() ? 0 : space.far_rank;
      return far;
    }

    void multi_contact_reference(Press &p, const HapticResult &result, std::uint32_t hips, const modalrt_basis *basis,
                                 modalrt_kernel *reference, double force_sign)
    {
      // The felt row: the trace row at felt_time.
      std::size_t first = p.first_row;
      for (std::size_t r = p.first_row; r <= p.last_row; ++r)
        if (result.trace[r * hips].time == p.felt_time)
          first = r;
      std::vector<modalrt_hip_input> inputs(hips);
      std::vector<std::uint32_t>     in_contact;
      for (std::uint32_t h = 0; h < hips; ++h)
        {
          const TraceSample &s = result.trace[first * hips + h];
          if (!s.in_contact)
            continue;
          in_contact.push_back(h);
          if (h != p.hip)
            p.other_vertices += (p.other_vertices.empty() ? "" : ";") + std::to_string(s.active_vertex);
        }
      p.felt_contacts = std::uint32_t(in_contact.size());
      if (in_contact.size() < 2 || !reference)
        return;
      modalrt_kernel_reset(reference);
      modalrt_kernel_switch_space(reference, p.space);
      std::vector<std::uint32_t> vertices;
      for (std::uint32_t h : in_contact)
        vertices.push_back(result.trace[first * hips + h].active_vertex);
      p.multi_note    = multi_contact_note(basis, p.space, vertices, p.multi_far_rank);
      p.multi_full_fe = p.multi_note.empty();
      const double *rest = modalrt_basis_display_vertices(basis);
      for (std::uint32_t h : in_contact)
        {
          const TraceSample &s = result.trace[first * hips + h];
          modalrt_kernel_contact_begin(reference, h, s.active_vertex);
          for (int c = 0; c < 3; ++c)
            {
              inputs[h].position[c] = rest[3 * std::size_t(s.active_vertex) + c];
              inputs[h].force[c]    = -force_sign * s.force[c]; // the force on the part
            }
        }
      std::vector<modalrt_hip_output> outputs(hips);
      if (modalrt_kernel_settle(reference, inputs.data(), hips) != MODALRT_OK ||
          modalrt_kernel_tick_admittance(reference, inputs.data(), hips, outputs.data()) != MODALRT_OK ||
          !outputs[p.hip].in_contact)
        {
          p.multi_note    = "the reference kernel refused the contacts";
          p.multi_full_fe = false;
          return;
        }
      const double moved[3] = {outputs[p.hip].position[0] - p.rest[0], outputs[p.hip].position[1] - p.rest[1],
                               outputs[p.hip].position[2] - p.rest[2]};
      const double u_n      = -dot3(moved, p.normal);
      p.multi_stiffness     = u_n > 0.0 ? p.felt_force / u_n : std::nan("");
    }

    // Runs `arguments` (arguments[0] is the program's path) and waits: its exit status, -1 if it
    // could not be started or did not exit normally.
    int run_program(const std::vector<std::string> &arguments)
    {
      std::vector<char *> argv;
      for (const std::string &a : arguments)
        argv.push_back(const_cast<char *>(a.c_str()));
      argv.push_back(nullptr);
      pid_t pid = 0;
      if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0)
        return -1;
      int status = 0;
      while (waitpid(pid, &status, 0) < 0)
        if (errno != EINTR)
          return -1;
      return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }

    // scripts/`script`: installed beside this program (<prefix>/bin/modal-rt finds
    // <prefix>/share/modal-haptics/scripts, MODAL_HAPTICS_SCRIPTS_FROM_BIN), else of the source tree
    // this tool was built from (__FILE__ is realtime/tools/run_outputs.cc there), else of a build
    // directory inside the repository (build/bin/modal-rt). Empty if none exists.
    std::string find_plot_script(const std::string &script)
    {
      namespace fs        = std::filesystem;
      const fs::path name = fs::path("scripts") / script;
      std::error_code code;
      std::vector<fs::path> places;
      const fs::path        exe = fs::read_symlink("/proc/self/exe", code);
#ifdef MODAL_HAPTICS_SCRIPTS_FROM_BIN
      if (!code)
        places.push_back(exe.parent_path() / MODAL_HAPTICS_SCRIPTS_FROM_BIN / name.filename());
#endif
      places.push_back(fs::path(__FILE__).parent_path() / "../.." / name);
      if (!code)
        places.push_back(exe.parent_path() / "../.." / name);
      for (const fs::path &place : places)
        if (fs::is_regular_file(place, code))
          return place.lexically_normal().string();
      return "";
    }
  } // namespace

  std::vector<Press> find_presses(const HapticResult &result, std::uint32_t hip_count, const modalrt_basis *basis,
                                  bool impedance, std::uint32_t validity_level, double force_scale)
  {
    std::vector<Press> presses;
    if (hip_count == 0)
      return presses;
    for (std::uint32_t h = 0; h < hip_count; ++h)
      collect_presses(result, hip_count, h, presses);
    // The reference kernel of the multi-contact presses: admittance, released only on request, no
    // switch on its own (the press's space is set).
    modalrt_kernel_def def   = modalrt_kernel_default_def();
    def.hip_capacity         = hip_count;
    def.auto_release         = 0;
    def.switch_rule          = MODALRT_SWITCH_NEVER;
    def.carry_state_on_switch = 0;
    def.snap_distance        = 1e-9;
    modalrt_kernel *reference = nullptr;
    if (hip_count > 1 && modalrt_kernel_create(basis, &def, &reference) != MODALRT_OK)
      reference = nullptr;
    for (Press &p : presses)
      {
        p.start = result.trace[p.first_row * hip_count].time;
        p.end   = result.trace[p.last_row * hip_count].time;
        p.space = result.trace[p.last_row * hip_count + p.hip].space;
        static_reference(p, result.trace[p.last_row * hip_count + p.hip], basis);
        felt_response(p, result, hip_count, impedance ? 1.0 : -1.0, force_scale);
        multi_contact_reference(p, result, hip_count, basis, reference, impedance ? 1.0 : -1.0);
        validity_of(p, result, hip_count, basis, validity_level);
      }
    modalrt_kernel_destroy(reference);
    // A contact period in which the hand never pushed into the part (a proxy's last row on another
    // vertex as it lifts off) has nothing to feel: it is no press.
    presses.erase(std::remove_if(presses.begin(), presses.end(), [](const Press &p) { return !(p.max_force > 0.0 && p.felt_force > 0.0); }),
                  presses.end());
    std::stable_sort(presses.begin(), presses.end(), [](const Press &a, const Press &b) { return a.start < b.start; });
    return presses;
  }

  bool write_presses(const std::string &path, const std::vector<Press> &presses, bool impedance,
                     std::uint32_t validity_level, std::string &error, double force_scale)
  {
    std::string text =
      "# modal-rt run presses: one row per contact period of a HIP (from trace.csv). Along the vertex's outward "
      "normal n: the force pushing into the part = force_sign * n . F(trace) [N], the displacement into the part "
      "= -n . (contact - frame - rest) [m]. compliance = n^T G n [m/N] of the static compliance G of the contact "
      "(full_fe 1: full FE; 0: modal part only, no full-FE reference). felt_*: at the end of the push (the last "
      "local maximum of the force reaching half its largest value, rows under the fail-safe rule or a force ramp "
      "of the kernel's own left out); felt_stiffness = felt_force / "
      "felt_displacement [N/m]; ratio = felt / static stiffness. With several HIPs in contact at the felt time "
      "(felt_contacts > 1, other_vertices): multi_static_stiffness = felt_force / the static normal displacement "
      "under all their loads at once, multi_full_fe 1 when it is the full-FE answer (every contact a candidate, "
      "every pair's cross compliance stored), multi_ratio = felt / multi_static_stiffness, multi_note why not full "
      "FE (a pair coupled by the basis's far field says so: the answer then holds its approximation). "
      "max_force_n the largest |F| of the press; validity_force_n the validity map's force at the press's point at "
      "validity_level_pct (nan: no value); beyond_validity 1 when a row was flagged MODALRT_HIP_BEYOND_VALIDITY, "
      "beyond_start_s its first row and beyond_force_n |F| there (nan: never). felt_force_n is the force at the hand (the one "
      "rendered), felt_stiffness_n_per_m the stiffness at the contact (the force on the part, felt_force / force_scale, "
      "over felt_displacement); hand_travel_m the device's own travel into the surface along n at felt_time_s (device "
      "units), stiffness_at_hand_n_per_m = felt_force / hand_travel (what the hand feels), force_scale the haptic "
      "mapping's force at the hand / force on the part (1 without a scale); design the design pressed (A: --basis, "
      "B: --design-b; a press is cut where the design felt changes)\n"
      "press,hip,space,space_name,vertex,start_s,end_s,nx,ny,nz,rest_x,rest_y,rest_z,compliance_m_per_n,full_fe,"
      "force_sign,max_contacts,felt_time_s,felt_force_n,felt_displacement_m,felt_stiffness_n_per_m,static_stiffness_n_per_m,"
      "ratio,felt_contacts,other_vertices,multi_static_stiffness_n_per_m,multi_full_fe,multi_ratio,multi_note,"
      "max_force_n,validity_level_pct,validity_force_n,beyond_validity,beyond_start_s,beyond_force_n,"
      "hand_travel_m,stiffness_at_hand_n_per_m,force_scale,design\n";
    char line[1024];
    for (std::size_t k = 0; k < presses.size(); ++k)
      {
        const Press &p = presses[k];
        std::snprintf(line, sizeof line,
                      "%zu,%u,%u,%s,%u,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%d,%d,%u,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", k,
                      p.hip, p.space, p.space_name.c_str(), p.vertex, p.start, p.end, p.normal[0], p.normal[1],
                      p.normal[2], p.rest[0], p.rest[1], p.rest[2], p.compliance, p.full_fe ? 1 : 0,
                      impedance ? 1 : -1, p.max_contacts, p.felt_time, p.felt_force, p.felt_displacement, p.felt_stiffness,
                      1.0 / p.compliance, p.felt_stiffness * p.compliance);
        text += line;
        text.pop_back(); // the multi-contact columns
        // 17 digits: the full-FE multi-contact answer is checked to 1e-9 (tests/realtime/test_run.cc).
        std::snprintf(line, sizeof line, ",%u,%s,%.17g,%s,%.17g,%s\n", p.felt_contacts, p.other_vertices.c_str(),
                      p.multi_stiffness, p.felt_contacts > 1 ? (p.multi_full_fe ? "1" : "0") : "",
                      p.felt_stiffness / p.multi_stiffness, p.multi_note.c_str());
        text += line;
        text.pop_back(); // the validity columns
        std::snprintf(line, sizeof line, ",%.9g,%u,%.9g,%d,%.9g,%.9g,%.9g,%.9g,%.9g,%c\n", p.max_force, validity_level,
                      p.validity_force, p.beyond ? 1 : 0, p.beyond_time, p.beyond_force, p.hand_travel,
                      p.hand_stiffness, force_scale, "AB"[p.design]);
        text += line;
      }
    return write_file_atomically(path, text, error);
  }

  bool plot_run(const std::string &script_name, const std::string &picture, const std::string &output_dir,
                std::string &notice)
  {
    const char       *python = "/usr/bin/python3";
    const std::string script = find_plot_script(script_name);
    const std::string how    = "apt-get install python3-matplotlib, then /usr/bin/python3 scripts/" + script_name + " " +
                            output_dir;
    if (script.empty() || access(python, X_OK) != 0)
      {
        notice = picture + " skipped: " + (script.empty() ? "scripts/" + script_name + " not found" : "no /usr/bin/python3") +
                 " (" + how + ")";
        return false;
      }
    const int status = run_program({python, script, output_dir});
    if (status == 0)
      return true;
    notice = status == 3 ? picture + " skipped: matplotlib is missing (" + how + ")"
                         : picture + " not written: " + script + " failed (exit status " + std::to_string(status) + ")";
    return false;
  }

  std::vector<std::string> space_names(const modalrt_basis *basis)
  {
    modalrt_basis_info info;
    modalrt_basis_get_info(basis, &info);
    std::vector<std::string> names;
    for (std::uint32_t k = 0; k < info.space_count; ++k)
      {
        modalrt_space_info space;
        modalrt_basis_get_space_info(basis, k, &space);
        names.push_back(csv_safe(space.name));
      }
    return names;
  }

  std::vector<SlideMargin> find_slide_margins(const HapticResult &result, std::uint32_t hip_count,
                                              const modalrt_basis *basis, std::uint32_t validity_level)
  {
    std::vector<SlideMargin> margins(result.slides.size());
    if (hip_count == 0)
      return margins;
    const std::size_t rows = result.trace.size() / hip_count;
    for (std::size_t k = 0; k < result.slides.size(); ++k)
      {
        const Slide &slide = result.slides[k];
        SlideMargin &m     = margins[k];
        // The trace's rows are in time order: the slide's are those from its start to its end.
        std::size_t r = 0, past = rows;
        while (r < past)
          {
            const std::size_t middle = r + (past - r) / 2;
            if (result.trace[middle * hip_count].time < slide.start)
              r = middle + 1;
            else
              past = middle;
          }
        for (; r < rows && result.trace[r * hip_count].time <= slide.end; ++r)
          {
            const TraceSample &s     = result.trace[r * hip_count + slide.hip];
            const double       force = std::sqrt(dot3(s.force, s.force));
            const double       limit = trace_validity_force(basis, s, validity_level); // NaN out of contact
            if (!std::isfinite(limit) || !(force > 0.0) || limit / force >= m.margin)
              continue;
            m.margin         = limit / force;
            m.time           = s.time;
            m.vertex         = s.active_vertex;
            m.triangle       = s.proxy_triangle;
            m.force          = force;
            m.validity_force = limit;
          }
      }
    return margins;
  }

  bool write_slides(const std::string &path, const std::vector<Slide> &slides, const std::vector<SlideMargin> &margins,
                    std::uint32_t validity_level, const std::vector<std::string> &space_names, std::string &error)
  {
    std::string text =
      "# modal-rt run slides: one row per slide of a HIP's proxy, from the first tick it slid to the last in one "
      "contact (every tick, not the trace's rows): length_m the proxy's path over the part (body frame) [m], "
      "max_force_step_n the largest |F_n - F_(n-1)| between consecutive ticks [N], max_force_n the largest |F| [N], "
      "passivity_energy_j the work the hand did on the kernel over it, sum of -F_(n-1) . (x_n - x_(n-1)) [J] "
      "(never far below 0 for a passive coupling); against the validity map at validity_level_pct: beyond_ticks "
      "the ticks flagged MODALRT_HIP_BEYOND_VALIDITY (every tick), lowest_margin the smallest validity_force / |F| "
      "over the slide's trace rows in contact (at the trace's rate; below 1: beyond; nan: no validity force "
      "along its path or no validity map), lowest_margin_s its row's time [s], lowest_margin_vertex and "
      "lowest_margin_triangle the proxy's active vertex and triangle there (-1: none), lowest_margin_force_n "
      "|F| there [N] and lowest_margin_validity_force_n the validity force there [N] (trace.csv's validity_force)\n"
      "slide,hip,start_s,end_s,space_start,space_start_name,space_end,space_end_name,ticks,sliding_ticks,length_m,"
      "max_force_step_n,max_force_n,passivity_energy_j,validity_level_pct,beyond_ticks,lowest_margin,"
      "lowest_margin_s,lowest_margin_vertex,lowest_margin_triangle,lowest_margin_force_n,"
      "lowest_margin_validity_force_n\n";
    char line[512];
    for (std::size_t k = 0; k < slides.size(); ++k)
      {
        const Slide       &s = slides[k];
        const SlideMargin &m = margins.at(k);
        std::snprintf(line, sizeof line, "%zu,%u,%.9g,%.9g,%u,%s,%u,%s,%llu,%llu,%.9g,%.9g,%.9g,%.9g", k, s.hip, s.start,
                      s.end, s.space_start, space_names.at(s.space_start).c_str(), s.space_end,
                      space_names.at(s.space_end).c_str(), (unsigned long long)s.ticks,
                      (unsigned long long)s.sliding_ticks, s.length, s.max_force_step, s.max_force, s.energy);
        text += line;
        std::snprintf(line, sizeof line, ",%u,%llu,%.9g,%.9g,%lld,%lld,%.9g,%.9g\n", validity_level,
                      (unsigned long long)s.beyond_ticks, m.margin, m.time, index_or_minus_one(m.vertex),
                      index_or_minus_one(m.triangle), m.force, m.validity_force);
        text += line;
      }
    return write_file_atomically(path, text, error);
  }

  double percentile(std::vector<float> values, double p)
  {
    if (values.empty())
      return 0.0;
    const std::size_t rank = std::min(values.size() - 1, std::size_t(std::ceil(p / 100.0 * values.size())) - (p > 0 ? 1 : 0));
    std::nth_element(values.begin(), values.begin() + rank, values.end());
    return values[rank];
  }

  RunReport summarize(const HapticResult &haptic, double rate)
  {
    RunReport r;
    r.latency_p50  = percentile(haptic.latency_us, 50.0);
    r.latency_p99  = percentile(haptic.latency_us, 99.0);
    r.latency_p999 = percentile(haptic.latency_us, 99.9);
    r.latency_max  = percentile(haptic.latency_us, 100.0);
    // Jitter: how far each tick's period (start to start) is from the nominal period.
    std::vector<float> jitter(haptic.period_us.size());
    for (std::size_t k = 0; k < jitter.size(); ++k)
      jitter[k] = float(std::fabs(haptic.period_us[k] - 1e6 / rate));
    r.jitter_p50  = percentile(jitter, 50.0);
    r.jitter_p99  = percentile(jitter, 99.0);
    r.jitter_p999 = percentile(jitter, 99.9);
    r.jitter_max  = percentile(jitter, 100.0);
    return r;
  }

  namespace
  {
    // Keys in the order realtime/README.md lists them. Doubles are written to round trip, NaN and
    // infinities as null (JSON has neither).
    using Json = nlohmann::ordered_json;

    Json vector3(const double *x) { return Json::array({x[0], x[1], x[2]}); }

    Json percentiles(double p50, double p99, double p999, double max)
    {
      return Json{{"p50", p50}, {"p99", p99}, {"p99_9", p999}, {"max", max}};
    }

    // Per HIP, the last inputs and outputs of the run.
    Json final_states(const HapticResult &h)
    {
      Json hips = Json::array();
      for (std::size_t k = 0; k < h.last_outputs.size(); ++k)
        {
          const modalrt_hip_output &out = h.last_outputs[k];
          const modalrt_hip_input  &in  = h.last_inputs[k];
          hips.push_back(Json{{"hip", k},
                              {"in_contact", out.in_contact},
                              {"active_vertex", index_or_minus_one(out.active_vertex)},
                              {"space", out.space},
                              {"device_position", vector3(in.position)},
                              {"input_force", vector3(in.force)},
                              {"position", vector3(out.position)},
                              {"force", vector3(out.force)}});
        }
      return hips;
    }

    // The kernel's counters and the loop's checks.
    void add_counters(const RunReport &r, Json &o)
    {
      const HapticResult &h        = *r.haptic;
      o["overruns"]                = h.overruns;
      o["missed_periods"]          = h.missed_periods;
      o["switches"]                = r.kernel.switch_count;
      o["max_switch_jump_m"]       = r.kernel.max_switch_jump;
      o["rejected_inputs"]         = r.kernel.rejected_ticks;
      o["rejected_frames"]         = r.kernel.rejected_frames;
      o["missing_inputs"]          = r.kernel.missing_ticks;
      o["fail_safe_ticks"]         = r.kernel.fail_safe_ticks;
      o["dropout_ticks"]           = r.kernel.dropout_ticks;
      o["clamped_forces"]          = r.kernel.clamped_forces;
      o["non_finite_outputs"]      = h.non_finite_outputs;
      o["max_press_distance_m"]    = r.max_press_distance;
      o["events_applied"]          = h.events_applied;
      o["failed_events"]           = h.failed_events;
      o["allocations_after_start"] = h.allocations;
      o["allocation_counting"]     = allocation_counting_method();
    }
  } // namespace

  std::string stats_json(const RunReport &r)
  {
    const HapticResult  &h = *r.haptic;
    const DisplayResult &d = *r.display;
    Json o{{"command", r.command},
           {"basis", r.basis},
           {"session", r.session},
           {"mode", r.mode},
           {"device", r.device},
           {"hips", r.hips},
           {"rate_hz", r.rate},
           {"duration_s", r.duration},
           {"ticks", h.ticks},
           {"simulated_s", h.ticks / r.rate},
           {"wall_s", h.wall_seconds},
           {"stopped_by", r.stopped_by},
           {"realtime_priority", h.realtime_priority}};
    o["tick_latency_us"]  = percentiles(r.latency_p50, r.latency_p99, r.latency_p999, r.latency_max);
    o["period_jitter_us"] = percentiles(r.jitter_p50, r.jitter_p99, r.jitter_p999, r.jitter_max);
    add_counters(r, o);
    o["coupling"] = Json{{"stiffness_n_per_m", r.coupling_stiffness},
                         {"damping_n_s_per_m", r.coupling_damping},
                         {"snap_distance_m", r.snap_distance}};
    o["display"]  = Json{{"reconstructions", d.reconstructions},
                         {"max_reconstruct_ms", d.max_reconstruct_ms},
                         {"frames_written", d.frames.size()}};
    o["device_counters"] = Json::object();
    for (const auto &[name, count] : r.device_counters)
      o["device_counters"][name] = count;
    o["passivity_energy_j"] = r.kernel.passivity_energy;
    o["at_hand"] = Json{{"profile", r.profile},
                        {"haptic_scale", r.mapping.haptic_scale},
                        {"force_scale", r.mapping.force_scale},
                        {"workspace_scale", r.mapping.workspace_scale},
                        {"band_top_stiffness_n_per_m", r.mapping.band_top_stiffness},
                        {"part_coupling_stiffness_n_per_m", r.mapping.part_coupling_stiffness},
                        {"series_share", r.mapping.series_share},
                        {"passivity_energy_j", r.kernel.hand_passivity_energy},
                        {"min_hip_passivity_energy_j", r.kernel.min_hip_passivity_energy},
                        {"passivity_damping_energy_j", r.kernel.passivity_damping_energy},
                        {"max_passivity_damping_n_s_per_m", r.kernel.max_passivity_damping},
                        {"passivity_damped_ticks", r.kernel.passivity_damped_ticks},
                        {"beyond_range_ticks", r.kernel.beyond_range_ticks}};
    if (!r.design_b.empty())
      {
        const BlindScore b = score(h.trials);
        o["designs"]       = Json{{"a", r.basis},
                                  {"b", r.design_b},
                                  {"fade_s", r.design_fade},
                                  {"switches", h.design_switches},
                                  {"blind", r.blind}};
        if (r.blind)
          o["designs"]["blind_trials"] = Json{{"seed", r.blind_seed},
                                              {"trials", h.trials.size()},
                                              {"scored", b.answered},
                                              {"correct", b.correct},
                                              {"chance", b.chance}};
      }
    o["presses"] = Json::array();
    for (const Press &p : r.presses)
      o["presses"].push_back(Json{{"hip", p.hip},
                                  {"design", std::string(1, "AB"[p.design])},
                                  {"vertex", p.vertex},
                                  {"space", p.space_name},
                                  {"stiffness_at_hand_n_per_m", p.hand_stiffness},
                                  {"stiffness_at_contact_n_per_m", p.felt_stiffness},
                                  {"static_stiffness_n_per_m", 1.0 / p.compliance},
                                  {"full_fe", p.full_fe}});
    o["slides"]             = Json::array();
    std::uint64_t slides_beyond = 0;
    for (std::size_t k = 0; k < h.slides.size(); ++k)
      {
        const Slide       &s = h.slides[k];
        const SlideMargin &m = r.slide_margins.at(k);
        o["slides"].push_back(Json{{"hip", s.hip},
                                   {"start_s", s.start},
                                   {"end_s", s.end},
                                   {"space_start", s.space_start},
                                   {"space_end", s.space_end},
                                   {"length_m", s.length},
                                   {"max_force_step_n", s.max_force_step},
                                   {"max_force_n", s.max_force},
                                   {"passivity_energy_j", s.energy},
                                   {"beyond_ticks", s.beyond_ticks},
                                   {"lowest_margin", m.margin},
                                   {"lowest_margin_s", m.time},
                                   {"lowest_margin_vertex", index_or_minus_one(m.vertex)},
                                   {"lowest_margin_triangle", index_or_minus_one(m.triangle)},
                                   {"lowest_margin_force_n", m.force},
                                   {"lowest_margin_validity_force_n", m.validity_force}});
        slides_beyond += s.beyond_ticks > 0;
      }
    o["slides_dropped"] = h.slides_dropped;
    o["creeps"]         = h.creeps;
    std::uint64_t beyond = 0;
    for (std::uint64_t n : h.beyond_validity_ticks)
      beyond += n;
    std::uint64_t presses_beyond = 0;
    for (const Press &p : r.presses)
      presses_beyond += p.beyond;
    o["validity"] = Json{{"map", r.validity_map},
                         {"level_percent", r.validity_level},
                         {"clamp", r.validity_clamp},
                         {"beyond_ticks", beyond},
                         {"beyond_ticks_per_hip", h.beyond_validity_ticks},
                         {"presses_beyond", presses_beyond},
                         {"slides_beyond", slides_beyond}};
    o["final"] = final_states(h);
    // Paths are bytes: invalid UTF-8 in one is replaced (U+FFFD), not an exception.
    return o.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
  }

  namespace
  {
    // Per press: the felt stiffness at the end of the push against the static stiffness of the contact.
    void print_presses(const std::vector<Press> &presses, bool two_designs)
    {
      constexpr std::size_t shown = 12; // one screen; presses.csv has them all
      if (!presses.empty())
        std::printf("  presses       %zu: at the end of the push, along the normal: at the hand = the device's force / "
                    "its own travel; at the contact = the force on the part / the contact point's displacement\n",
                    presses.size());
      for (std::size_t k = 0; k < std::min(presses.size(), shown); ++k)
        {
          const Press &p = presses[k];
          std::printf("  press %-7zu HIP %u, %s%s vertex %u, %.2f-%.2f s%s: at the hand %.4g N/mm (%.3g N, %.3g mm at "
                      "%.2f s); at the contact %.4g N/mm; %s %.4g N/mm; ratio %.3f\n",
                      k, p.hip, two_designs ? (p.design ? "design B " : "design A ") : "", p.space_name.c_str(),
                      p.vertex, p.start, p.end,
                      p.max_contacts > 1 ? " (several HIPs in contact)" : "", 1e-3 * p.hand_stiffness, p.felt_force,
                      1e3 * p.hand_travel, p.felt_time, 1e-3 * p.felt_stiffness,
                      p.full_fe ? "full-FE static" : "modal-only static (no full-FE reference)",
                      1e-3 / p.compliance, p.felt_stiffness * p.compliance);
          if (p.felt_contacts > 1 && std::isfinite(p.multi_stiffness))
            std::printf("  %-13s with the %u contacts' loads together (vertices %u;%s): %s %.4g N/mm; ratio %.3f\n", "",
                        p.felt_contacts, p.vertex, p.other_vertices.c_str(),
                        p.multi_full_fe    ? "full-FE static (cross compliance)"
                        : p.multi_far_rank ? ("static (" + p.multi_note + ")").c_str()
                                           : ("static, no full-FE reference (" + p.multi_note + ")").c_str(),
                        1e-3 * p.multi_stiffness, p.felt_stiffness / p.multi_stiffness);
        }
      if (presses.size() > shown)
        std::printf("  ...           %zu more presses in presses.csv\n", presses.size() - shown);
    }

    // After a press's or slide's line beyond its validity force, with --validity-clamp.
    constexpr const char *clamp_note = "; the rendered force held at it (--validity-clamp)";

    // Per press, against its validity force at the kernel's level (a map in the basis only).
    void print_press_validity(const RunReport &r)
    {
      if (!r.validity_map)
        {
          if (!r.presses.empty()) // said once, as each slide says it
            std::printf("  validity      no validity map in the basis\n");
          return;
        }
      constexpr std::size_t shown = 12;
      for (std::size_t k = 0; k < std::min(r.presses.size(), shown); ++k)
        {
          const Press &p = r.presses[k];
          if (p.beyond)
            std::printf("  validity %-4zu beyond its validity force: F%u = %.3g N, from %.2f s at %.3g N (up to %.3g N)%s\n",
                        k, r.validity_level, p.validity_force, p.beyond_time, p.beyond_force, p.max_force,
                        r.validity_clamp ? clamp_note : "");
          else if (std::isfinite(p.validity_force))
            std::printf("  validity %-4zu within its validity force: up to %.3g N, F%u = %.3g N\n", k, p.max_force,
                        r.validity_level, p.validity_force);
          else
            std::printf("  validity %-4zu no validity force at its point (up to %.3g N)\n", k, p.max_force);
        }
    }
    // Under a slide's line, the slide against its validity force at the kernel's level: the ticks
    // beyond it and the lowest margin along the path (validity force / |F|), as the presses' lines.
    void print_slide_validity(const RunReport &r, const Slide &s, const SlideMargin &m)
    {
      if (!r.validity_map)
        {
          std::printf("  %-13s no validity map\n", "");
          return;
        }
      char lowest[256];
      if (std::isfinite(m.margin))
        std::snprintf(lowest, sizeof lowest,
                      "lowest F%u / |F| = %.3g at %.2f s, vertex %lld (triangle %lld): F%u = %.3g N at %.3g N (up to %.3g N)",
                      r.validity_level, m.margin, m.time, index_or_minus_one(m.vertex), index_or_minus_one(m.triangle),
                      r.validity_level, m.validity_force, m.force, s.max_force);
      else
        std::snprintf(lowest, sizeof lowest, "no validity force on its trace rows (up to %.3g N)", s.max_force);
      if (s.beyond_ticks > 0)
        std::printf("  %-13s beyond its validity force on %llu of %llu ticks: %s%s\n", "",
                    (unsigned long long)s.beyond_ticks, (unsigned long long)s.ticks, lowest,
                    r.validity_clamp ? clamp_note : "");
      else if (std::isfinite(m.margin))
        std::printf("  %-13s within its validity force: %s\n", "", lowest);
      else
        std::printf("  %-13s no validity force along its path (up to %.3g N)\n", "", s.max_force);
    }

    // Per slide: how far the proxy went, the largest force change per tick, the passivity observer,
    // and the validity force.
    void print_slides(const RunReport &r)
    {
      const std::vector<Slide> &slides = r.haptic->slides;
      constexpr std::size_t     shown  = 12;
      if (!slides.empty())
        std::printf("  slides        %zu: the proxy's path, the largest force change per tick, the energy the hand "
                    "put in (passive: >= 0)\n",
                    slides.size());
      for (std::size_t k = 0; k < std::min(slides.size(), shown); ++k)
        {
          const Slide &s = slides[k];
          std::printf("  slide %-7zu HIP %u, %s -> %s, %.2f-%.2f s: %.1f mm slid (%llu of %llu ticks sliding); largest "
                      "force change %.3g N per tick (force up to %.3g N); passivity %+.3g J\n",
                      k, s.hip, r.space_names.at(s.space_start).c_str(), r.space_names.at(s.space_end).c_str(), s.start,
                      s.end, 1e3 * s.length, (unsigned long long)s.sliding_ticks, (unsigned long long)s.ticks,
                      s.max_force_step, s.max_force, s.energy);
          print_slide_validity(r, s, r.slide_margins.at(k));
        }
      if (slides.size() > shown)
        std::printf("  ...           %zu more slides in slides.csv\n", slides.size() - shown);
      if (r.haptic->slides_dropped > 0)
        std::printf("  slides        %llu more not recorded (beyond the records' capacity)\n",
                    (unsigned long long)r.haptic->slides_dropped);
    }

    // The verdict on the schedule: late ticks (overruns) and lost ones (missed periods) against the
    // threshold of realtime/README.md. A late tick repeats the last force for part of a period; up
    // to one tick in a thousand (one a second at 1 kHz, isolated) is below what a hand feels.
    constexpr double late_tick_threshold = 1e-3;

    void print_timing_verdict(const HapticResult &h)
    {
      const std::uint64_t late     = h.overruns + h.missed_periods;
      const double        fraction = h.ticks > 0 ? double(late) / double(h.ticks) : 0.0;
      const bool          fine     = fraction <= late_tick_threshold;
      std::printf("  timing        %s: %llu of %llu ticks late or lost (%.3g %%), %s the %.1f %% a hand cannot feel%s\n",
                  fine ? "fine" : "warning", (unsigned long long)late, (unsigned long long)h.ticks, 100.0 * fraction,
                  fine ? "under" : "above", 100.0 * late_tick_threshold,
                  fine ? "" : " (real-time priority for the haptic thread, a larger --spin-us or a quieter machine)");
    }
  } // namespace

  namespace
  {
    // Two designs felt in turn: which is which, the switches, and the blind mode's score.
    void print_designs(const RunReport &r)
    {
      const HapticResult &h = *r.haptic;
      std::printf("  designs       A %s, B %s: %llu switches, each faded over %g s (both kernels ticked every tick)\n",
                  r.basis.c_str(), r.design_b.c_str(), (unsigned long long)h.design_switches, r.design_fade);
      if (!r.blind)
        return;
      const BlindScore b = score(h.trials);
      std::printf("  blind A/B     seed %u, %zu trials: %u of %u scored answers right (the stiffer slot by the "
                  "felt-stiffness maps); %.3g chance of as many by guessing; blind.csv\n",
                  r.blind_seed, h.trials.size(), b.correct, b.answered, b.chance);
    }
  } // namespace

  void print_summary(const RunReport &r)
  {
    const HapticResult  &h = *r.haptic;
    const DisplayResult &d = *r.display;
    std::printf("modal-rt %s: %s, session %s\n", r.command.c_str(), r.basis.c_str(), r.session.c_str());
    std::printf("  mode          %s, device %s, %u HIP(s), coupling %g N/m, %g N s/m\n", r.mode.c_str(),
                r.device.c_str(), r.hips, r.coupling_stiffness, r.coupling_damping);
    if (!r.scale_line.empty())
      std::printf("  haptic scale  %s\n", r.scale_line.c_str());
    std::printf("  passivity     at the hand: observer %.3g mJ (lowest per HIP over a contact %.3g mJ), the controller "
                "dissipated %.3g mJ in %llu HIP ticks (damping up to %.3g N s/m); %llu ticks at the stable-stiffness wall\n",
                1e3 * r.kernel.hand_passivity_energy, 1e3 * r.kernel.min_hip_passivity_energy,
                1e3 * r.kernel.passivity_damping_energy, (unsigned long long)r.kernel.passivity_damped_ticks,
                r.kernel.max_passivity_damping, (unsigned long long)r.kernel.beyond_range_ticks);
    std::printf("  ticks         %llu at %g Hz: %.3f s simulated, %.3f s wall, stopped by %s\n",
                (unsigned long long)h.ticks, r.rate, h.ticks / r.rate, h.wall_seconds, r.stopped_by.c_str());
    std::printf("  tick latency  p50 %.2f us, p99 %.2f us, p99.9 %.2f us, max %.2f us (period %.1f us)\n",
                r.latency_p50, r.latency_p99, r.latency_p999, r.latency_max, 1e6 / r.rate);
    std::printf("  period jitter p99 %.2f us, max %.2f us; overruns %llu, missed periods %llu; %s\n", r.jitter_p99,
                r.jitter_max, (unsigned long long)h.overruns, (unsigned long long)h.missed_periods,
                h.realtime_priority ? "SCHED_FIFO" : "default scheduling (SCHED_FIFO not granted)");
    print_timing_verdict(h);
    std::printf("  kernel        switches %llu (max jump %.3g m), rejected inputs %llu, rejected frames %llu, "
                "clamped forces %llu\n",
                (unsigned long long)r.kernel.switch_count, r.kernel.max_switch_jump,
                (unsigned long long)r.kernel.rejected_ticks, (unsigned long long)r.kernel.rejected_frames,
                (unsigned long long)r.kernel.clamped_forces);
    std::printf("  checks        non-finite outputs %llu, allocations after start %llu, events %llu (%llu refused)\n",
                (unsigned long long)h.non_finite_outputs, (unsigned long long)h.allocations,
                (unsigned long long)h.events_applied, (unsigned long long)h.failed_events);
    if (!r.device_counters.empty())
      {
        std::printf("  device       ");
        for (const auto &[name, count] : r.device_counters)
          std::printf(" %s %llu", name.c_str(), (unsigned long long)count);
        std::printf("\n");
      }
    std::printf("  display       %llu reconstructions (max %.2f ms), %zu frames written%s%s\n",
                (unsigned long long)d.reconstructions, d.max_reconstruct_ms, d.frames.size(),
                d.error.empty() ? "" : "; ERROR: ", d.error.c_str());
    if (!r.design_b.empty())
      print_designs(r);
    print_presses(r.presses, !r.design_b.empty());
    print_press_validity(r);
    print_slides(r);
    for (std::size_t k = 0; k < h.last_outputs.size(); ++k)
      {
        const modalrt_hip_output &o = h.last_outputs[k];
        std::printf("  HIP %zu at end  %s, space %u, position [%.6g %.6g %.6g] m, force [%.4g %.4g %.4g] N\n", k,
                    o.in_contact ? ("vertex " + std::to_string(o.active_vertex)).c_str() : "free", o.space,
                    o.position[0], o.position[1], o.position[2], o.force[0], o.force[1], o.force[2]);
      }
    std::printf("  outputs       %s/{stats.json, trace.csv, presses.csv, slides.csv, frames.pvd, frames/%s%s%s}\n",
                r.output_dir.c_str(), r.blind ? ", blind.csv" : "", r.plot_written ? ", force_displacement.png" : "",
                r.slide_plot_written ? ", slide_stiffness.png" : "");
  }
} // namespace modalrt_tool
