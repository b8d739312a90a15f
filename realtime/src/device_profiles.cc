// Device profiles: the published specs of classes of haptic device, by name (modalrt.h,
// modalrt_device_profile_find). Stiffness, damping, force and workspace radius of the impedance
// devices are CHAI3D 3.3.0's device classes (src/devices/CPhantomDevices.cpp, CDeltaDevices.cpp:
// m_maxLinearStiffness, m_maxLinearDamping, m_maxLinearForce at the 1 kHz servo rate); the
// workspace extents are the makers' data sheets; realtime/README.md lists the sources per value.
// No device's physical damping is published: b = 0 (unknown), so each needs the passivity controller.
#include "error.h"

#include <modalrt/modalrt.h>

#include <cstring>
#include <string>

namespace
{
  struct DeviceProfile
  {
    const char *name;
    double      max_force, max_stiffness, max_damping; // [N], [N/m], [N s/m]
    double      workspace[3];                           // [m]
    uint32_t    kind;
  };

  constexpr DeviceProfile profiles[] = {
    {"touch", 3.3, 400.0, 4.0, {0.160, 0.120, 0.070}, MODALRT_DEVICE_IMPEDANCE},
    {"omni", 3.3, 700.0, 5.0, {0.160, 0.120, 0.070}, MODALRT_DEVICE_IMPEDANCE},
    {"desktop", 7.9, 1000.0, 5.0, {0.160, 0.130, 0.130}, MODALRT_DEVICE_IMPEDANCE},
    {"falcon", 8.0, 3000.0, 20.0, {0.102, 0.102, 0.102}, MODALRT_DEVICE_IMPEDANCE},
    {"omega.x", 12.0, 5000.0, 30.0, {0.160, 0.160, 0.110}, MODALRT_DEVICE_IMPEDANCE},
    {"sigma.7", 12.0, 4000.0, 30.0, {0.190, 0.190, 0.130}, MODALRT_DEVICE_IMPEDANCE},
    {"lambda.7", 12.0, 8000.0, 30.0, {0.240, 0.240, 0.180}, MODALRT_DEVICE_IMPEDANCE},
    // A generic admittance device of the HapticMaster's class (force in, position out): it renders
    // the part's stiffness as it is, so its "stable stiffness" is its own position loop's.
    {"admittance", 250.0, 5e4, 100.0, {0.40, 0.36, 0.40}, MODALRT_DEVICE_ADMITTANCE},
  };
} // namespace

const char *modalrt_device_profile_name(uint32_t index)
{
  return index < sizeof profiles / sizeof profiles[0] ? profiles[index].name : nullptr;
}

int modalrt_device_profile_find(const char *name, modalrt_device_def *spec)
{
  if (!name || !spec)
    return modalrt::failed(MODALRT_ERROR_INVALID_ARGUMENT, "modalrt_device_profile_find: null argument");
  for (const DeviceProfile &p : profiles)
    if (std::strcmp(p.name, name) == 0)
      {
        *spec                  = modalrt_device_default_def();
        spec->max_force        = p.max_force;
        spec->max_stiffness    = p.max_stiffness;
        spec->max_damping      = p.max_damping;
        spec->physical_damping = 0.0; // not published
        spec->rate             = 1000.0;
        std::memcpy(spec->workspace, p.workspace, sizeof p.workspace);
        spec->kind = p.kind;
        return MODALRT_OK;
      }
  std::string names;
  for (const DeviceProfile &p : profiles)
    names += std::string(names.empty() ? "" : ", ") + p.name;
  const std::string message = "modalrt_device_profile_find: no device profile '" + std::string(name) + "' (" + names + ")";
  return modalrt::failed(MODALRT_ERROR_INVALID_ARGUMENT, message.c_str());
}
