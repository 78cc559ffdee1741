// shrefract: the command line tool (bake, render, report, view, info).
#include <cstdio>
#include <cstring>
#include <string>

#include "cli/commands.h"
#include "cli/interrupt.h"

namespace {

void printUsage(FILE* out) {
  std::fprintf(out,
               "usage: shrefract COMMAND [ARGS]\n"
               "commands:\n"
               "  bake SCENE -o FILE.shrf       trace, fit and quantize a refraction field\n"
               "  info FILE.shrf [--json]       print a field file's header, settings and statistics\n"
               "  render FIELD.shrf|SCENE -o OUT.png|exr\n"
               "                                render a baked field (any encoding) or a scene (single\n"
               "                                interface; exact or full tree: the CPU references)\n"
               "  view FIELD.shrf|SCENE         interactive window: orbit, absorption, environments, SH order\n"
               "  report [SCENES...] -o DIR     error against run time for every setting (report.md, plots)\n"
               "  merge PARTS... -o FILE.shrf   join the parts of `bake --shard I/N` into one field\n"
               "  help                          this text; `shrefract COMMAND --help` for a command\n"
               "  version                       print the version\n");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    printUsage(stderr);
    return 2;
  }
  // Before any thread starts (cli/interrupt.h): an interrupt then removes staged output.
  shrefract::cli::installInterruptCleanup();
  const std::string command = argv[1];
  if (command == "render") return shrefract::cli::renderCommand(argc, argv);
  if (command == "bake") return shrefract::cli::bakeCommand(argc, argv);
  if (command == "info") return shrefract::cli::infoCommand(argc, argv);
  if (command == "view") return shrefract::cli::viewCommand(argc, argv);
  if (command == "report") return shrefract::cli::reportCommand(argc, argv);
  if (command == "merge") return shrefract::cli::mergeCommand(argc, argv);
  if (command == "help" || command == "--help" || command == "-h") {
    printUsage(stdout);
    return 0;
  }
  if (command == "version" || command == "--version") {
    std::printf("shrefract 0.1.0\n");
    return 0;
  }
  std::fprintf(stderr, "shrefract: unknown command '%s' (try `shrefract help`)\n", command.c_str());
  return 2;
}
