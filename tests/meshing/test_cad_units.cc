// The length unit a STEP or IGES file declares (meshing::declared_length_unit): the files are written
// here, as small as the parser needs (a STEP unit entity, an IGES start and global section).
#include "meshing_check.h"
#include "scene_mesher.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

using namespace modal_haptics::meshing;
namespace fs = std::filesystem;

using meshing_test::check;
using meshing_test::failures;

namespace
{
  const fs::path folder = fs::temp_directory_path() / ("cad_units_" + std::to_string(::getpid()));

  std::string write(const std::string &name, const std::string &text)
  {
    const std::string path = (folder / name).string();
    std::ofstream(path) << text;
    return path;
  }

  void check_unit(const std::string &file, const std::string &name, const std::string &code, const double metres)
  {
    const DeclaredUnit unit = declared_length_unit(file);
    check(unit.name == name && unit.occ_code == code && std::abs(unit.metres - metres) <= 1e-15 * metres,
          fs::path(file).filename().string() + ": '" + unit.name + "' (" + unit.occ_code + ", " +
            std::to_string(unit.metres) + " m), expected '" + name + "'");
  }

  std::string step_with(const std::string &unit_entity)
  {
    return "ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('AUTOMOTIVE_DESIGN'));\nENDSEC;\nDATA;\n"
           "#10 = UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-07),#11,'distance_accuracy_value','');\n"
           "#11 = " + unit_entity + ";\n"
           "#12 = ( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) );\nENDSEC;\nEND-ISO-10303-21;\n";
  }

  // An IGES file's start and global sections; 'global' is cut into 72-column G records.
  std::string iges_with(const std::string &global)
  {
    std::string text = std::string(72, ' ').replace(0, 9, "unit test") + "S      1\n";
    int         line = 0;
    for (std::size_t at = 0; at < global.size(); at += 72)
      {
        std::string record = global.substr(at, 72);
        record.resize(72, ' ');
        const std::string number = std::to_string(++line);
        text += record + "G" + std::string(7 - number.size(), ' ') + number + "\n";
      }
    return text + std::string(72, ' ') + "T      1\n";
  }

  std::string iges_global(const std::string &units_flag, const std::string &units_name)
  {
    return "1H,,1H;,4Hpart,8Hpart.igs,4Hgmsh,3H4.8,32,38,6,308,15,4Hpart,1.," + units_flag + "," + units_name +
           ",1,0.01,15H20261124.120000,1.E-07,0.2,2Hme,2Hus,11,0,15H20261124.120000;";
  }
} // namespace

int main()
{
  fs::create_directories(folder);
  check_unit(write("mm.step", step_with("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )")), "millimetre",
             "MM", 1e-3);
  check_unit(write("m.step", step_with("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT($,.METRE.) )")), "metre", "M", 1.);
  check_unit(write("cm.stp", step_with("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.CENTI.,.METRE.) )")), "centimetre",
             "CM", 1e-2);
  check_unit(write("inch.step", step_with("( CONVERSION_BASED_UNIT('INCH',#13) LENGTH_UNIT() NAMED_UNIT(#14) )")),
             "inch", "INCH", 0.0254);
  check_unit(write("none.step", "ISO-10303-21;\nDATA;\n#1 = CARTESIAN_POINT('',(0.,0.,0.));\nENDSEC;\n"), "", "", 0.);
  check_unit(write("m.igs", iges_with(iges_global("6", "1HM"))), "metre", "M", 1.);
  check_unit(write("mm.iges", iges_with(iges_global("2", "2HMM"))), "millimetre", "MM", 1e-3);
  check_unit(write("inch.igs", iges_with(iges_global("3", "4HINCH"))), "inch", "INCH", 0.0254);
  check_unit(write("part.brep", "DBRep_DrawableShape\n"), "", "", 0.);
  try
    {
      declared_length_unit(write("bad.igs", iges_with(iges_global("12", "2HXX"))));
      check(false, "IGES units flag 12 refused (no exception)");
    }
  catch (const MeshingError &e)
    {
      check(std::string(e.what()).find("units flag '12'") != std::string::npos,
            std::string("IGES units flag 12 refused: ") + e.what());
    }
  fs::remove_all(folder);
  std::cout << failures << " failure(s)" << std::endl;
  return failures == 0 ? 0 : 1;
}
