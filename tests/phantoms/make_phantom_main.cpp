// cvtmesh-phantom: writes an analytic phantom as a label image (for assets/ and experiments).
#include <iostream>

#include <CLI/CLI.hpp>

#include "base/errors.h"
#include "io/image_io.h"
#include "phantoms.h"

int main(int argc, char** argv) {
  CLI::App app{"Write an analytic phantom (sphere, torus, slab, hollow, two-spheres) as an image"};
  std::string shape = "torus", out;
  std::vector<double> spacing{1.0, 1.0, 1.5};
  double size = 20.0, rotate_deg = 0.0;
  app.add_option("SHAPE", shape, "sphere | torus | slab | hollow | two-spheres")->required();
  app.add_option("-o,--output", out, "Output image (.nii.gz, .nrrd, .mha, .inr, ...)")->required();
  app.add_option("--size", size, "Characteristic size (mm): radius, major radius, width");
  app.add_option("--spacing", spacing, "Voxel spacing (mm)")->expected(3);
  app.add_option("--rotate", rotate_deg, "Rotate the grid about (1,1,1) by this angle (degrees)");
  CLI11_PARSE(app, argc, argv);
  try {
    const cvt::Vec3 c{10.0, -20.0, 30.0};  // an origin away from 0 catches frame mistakes
    cvt::Phantom p;
    if (shape == "sphere") p = cvt::sphere_phantom(c, size);
    else if (shape == "torus") p = cvt::torus_phantom(c, size, 0.4 * size);
    else if (shape == "slab") p = cvt::slab_phantom(c, 0.3 * size, size);
    else if (shape == "hollow") p = cvt::hollow_sphere_phantom(c, 0.5 * size, size);
    else if (shape == "two-spheres") p = cvt::two_spheres_phantom(c, 0.5 * size, 0.0);
    else throw cvt::InputError("unknown phantom shape '" + shape + "'");
    const auto dir = cvt::rotation_matrix({1, 1, 1}, rotate_deg * 3.14159265358979323846 / 180.0);
    const cvt::Grid g = cvt::grid_around(p, {spacing[0], spacing[1], spacing[2]}, dir);
    cvt::write_image(cvt::rasterize(p, g), out);
  } catch (const std::exception& e) {
    std::cerr << "cvtmesh-phantom: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
