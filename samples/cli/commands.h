#pragma once

namespace shrefract::cli {

// Each command returns the process exit code: 0 success, 1 failure, 2 usage error, and for the
// commands that need the GPU (render's engine modes, report) kExitNoDevice when the machine has no
// Vulkan driver or device (tests skip on it; docs/bad-input.md).
inline constexpr int kExitNoDevice = 3;

int renderCommand(int argc, char** argv);
int bakeCommand(int argc, char** argv);
int infoCommand(int argc, char** argv);
int viewCommand(int argc, char** argv);  // samples/viewer/view_command.cpp
int reportCommand(int argc, char** argv);
int mergeCommand(int argc, char** argv);  // shard_commands.cpp

}  // namespace shrefract::cli
