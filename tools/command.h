// command.h — how a tools/cmd_*.cpp file adds a subcommand to the `t2m` binary without touching main.cpp.
//
//   static void add_bench(CLI::App& app) { auto* c = app.add_subcommand("bench", "..."); c->callback(...); }
//   T2M_COMMAND(add_bench);
//
// Errors: throw t2m::Error (or any std::exception); main prints "t2m: <message>" and exits with status 1.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace t2m::cli {

using CommandAdder = void (*)(CLI::App&);
std::vector<CommandAdder>& command_registry();
struct CommandRegistrar {
  explicit CommandRegistrar(CommandAdder f) { command_registry().push_back(f); }
};

}  // namespace t2m::cli

#define T2M_COMMAND_CAT2(a, b) a##b
#define T2M_COMMAND_CAT(a, b) T2M_COMMAND_CAT2(a, b)
#define T2M_COMMAND(fn) static ::t2m::cli::CommandRegistrar T2M_COMMAND_CAT(t2m_cmd_reg_, __LINE__)(fn)
