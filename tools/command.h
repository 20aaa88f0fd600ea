// command.h — how a tools/cmd_*.cpp file adds a subcommand to the `t2m` binary without touching main.cpp.
//
//   static void add_bench(CLI::App& app) { auto* c = app.add_subcommand("bench", "..."); c->callback(...); }
//   T2M_COMMAND(add_bench);
//
// Grouped leaves (`t2m train bfm`, `t2m eval track`): auto* g = command_group(app, "train", "train a model");
//   g->add_subcommand("bfm", "...");  Groups in use: train (text, evaluator, bfm, vbb, gen), eval (motions, track, text2bfm, compose).
//
// Errors: throw t2m::Error (or any std::exception); main prints "t2m: <message>" and exits with status 1.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace t2m::cli {

using CommandAdder = void (*)(CLI::App&);
std::vector<CommandAdder>& command_registry();
struct CommandRegistrar {
  explicit CommandRegistrar(CommandAdder f) { command_registry().push_back(f); }
};

// A shared parent command such as `t2m train` or `t2m eval`: returns the existing subcommand `name` of `app`, or
// creates it (requiring one of its own subcommands). Lets several cmd_*.cpp files add `t2m train <model>` leaves
// regardless of static-initialisation order.
inline CLI::App* command_group(CLI::App& app, const std::string& name, const std::string& description) {
  try {
    return app.get_subcommand(name);
  } catch (const CLI::OptionNotFound&) {
    CLI::App* group = app.add_subcommand(name, description);
    group->require_subcommand(1);
    return group;
  }
}

}  // namespace t2m::cli

#define T2M_COMMAND_CAT2(a, b) a##b
#define T2M_COMMAND_CAT(a, b) T2M_COMMAND_CAT2(a, b)
#define T2M_COMMAND(fn) static ::t2m::cli::CommandRegistrar T2M_COMMAND_CAT(t2m_cmd_reg_, __LINE__)(fn)
