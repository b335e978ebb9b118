// cvtmesh: tetrahedral Delaunay meshes from 3D medical images (see README.md).
#include <cstdio>
#include <exception>
#include <iostream>

#include "commands.h"
#include "base/errors.h"
#include "base/huge_page_malloc.h"
#include "signal_cancel.h"

int main(int argc, char** argv) {
  cvt::reexec_with_huge_page_malloc(argv);
  CLI::App app{"cvtmesh: CVT-based Delaunay tetrahedral meshes from 3D medical images"};
  app.require_subcommand(1);
  cvt::cli::add_info_command(app);
  cvt::cli::add_mesh_command(app);
  cvt::cli::add_quality_command(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // One line, like every other error (CLI11's own output adds a second).
    std::cerr << "cvtmesh: " << e.what() << " (run with --help for more information)\n";
    return e.get_exit_code();
  } catch (const cvt::Cancelled&) {
    cvt::cli::claim_interrupt_exit();  // the watchdog must not print it a second time
    std::cerr << "cvtmesh: cancelled; nothing was written\n";
    return 130;
  } catch (const cvt::InputError& e) {
    std::cerr << "cvtmesh: " << e.what() << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "cvtmesh: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "cvtmesh: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
