// mfns-flash BLOB TARGET: install a parameter blob on a flyer (flash.h).
//   TARGET = a store directory, or ssh://[user@]host[:port]/dir
// Exit 0 on success (the blob's generation is confirmed active), 1 with one line on stderr.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/limits.h"
#include "host/flash/flash_cli.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

int Run(int argc, char** argv) {
  CLI::App app;
  FlashCommandLine cl;
  try {
    ParseFlashCommandLine(app, argc, argv, &cl);
    const std::string data = ReadFile(cl.blob_path, limits::kMaxBlobBytes);
    const std::vector<std::uint8_t> blob(data.begin(), data.end());
    const FlashResult r = Flash(blob, cl.target, cl.options);
    std::cout << r.install_output;
    std::cout << "mfns-flash: " << cl.target.Display() << ": generation " << r.active_generation << " (rig "
              << r.active_rig_id << ") is active\n";
    return 0;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::cerr << "mfns-flash: " << e.what() << " (--help for usage)\n";
    return 1;
  } catch (const UserError& e) {
    std::cerr << "mfns-flash: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace
}  // namespace mfns::host

int main(int argc, char** argv) { return mfns::host::Run(argc, argv); }
