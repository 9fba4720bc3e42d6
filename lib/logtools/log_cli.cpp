#include "logtools/log_cli.hpp"

#include <CLI/CLI.hpp>
#include <cmath>
#include <fstream>
#include <iostream>

#include "logtools/export.hpp"
#include "logtools/frames.hpp"
#include "logtools/latency.hpp"
#include "logtools/log_info.hpp"

namespace harvest::logtools {

int log_main(int argc, char** argv) {
  CLI::App app{"Inspect harvest LCM logs: info, export, frames, latency (docs/log-tools.md)"};
  app.require_subcommand(1);

  std::string log_path, channel, format = "csv", out_file, detections, out_dir;
  std::vector<std::string> fields;
  InfoOptions info_opt;
  double min_gap_s = 0.2;
  int every = 1, max_frames = 10;

  auto* info = app.add_subcommand("info", "channels, types by fingerprint, counts, rates, time span, gaps");
  info->add_option("log", log_path, "LCM log file")->required();
  info->add_option("--gap-factor", info_opt.gap_factor, "a gap is longer than this many median intervals")
      ->capture_default_str();
  info->add_option("--min-gap", min_gap_s, "... and longer than this [s]")->capture_default_str();

  auto* exp = app.add_subcommand("export", "one channel as CSV or JSON lines, one row per message");
  exp->add_option("log", log_path, "LCM log file")->required();
  exp->add_option("channel", channel, "channel name")->required();
  exp->add_option("--format", format, "csv or jsonl")->check(CLI::IsMember({"csv", "jsonl"}))->capture_default_str();
  exp->add_option("--fields", fields, "keep only these field paths (prefixes, indices as [])")
      ->delimiter(',')
      ->allow_extra_args(false);
  exp->add_option("-o,--output", out_file, "output file (default: stdout)");

  auto* frm = app.add_subcommand("frames", "camera frames as PNG with the detections drawn on them");
  frm->add_option("log", log_path, "LCM log file")->required();
  frm->add_option("channel", channel, "image channel, e.g. CAMERA_FIXED")->required();
  frm->add_option("--detections", detections, "fruit_detections_t channel to overlay, e.g. FRUIT_FIXED");
  frm->add_option("--out", out_dir, "output folder")->required();
  frm->add_option("--every", every, "every n-th frame")->check(CLI::PositiveNumber)->capture_default_str();
  frm->add_option("--max", max_frames, "at most this many frames")->check(CLI::PositiveNumber)->capture_default_str();
  std::string frame_format = "png";
  frm->add_option("--format", frame_format, "png, or bmp (uncompressed: a camera driver reads it faster)")
      ->check(CLI::IsMember({"png", "bmp"}))
      ->capture_default_str();
  bool sensor_size = false;
  frm->add_flag("--sensor-size", sensor_size,
                "the frames alone (no label, no overlay) at the size of the sensor region they show: a folder "
                "harvest-camera replays as the same sensor");

  auto* lat = app.add_subcommand("latency", "age, transport and per-hop time of every message, from the headers");
  lat->add_option("log", log_path, "LCM log file")->required();
  std::string json_out;
  LatencyOptions lat_opt;
  lat->add_option("--json", json_out, "also write the report as JSON to this file");
  lat->add_option("--command-channel", lat_opt.command_channel, "the channel frames are followed to")
      ->capture_default_str();
  double command_period_ms = 0;
  lat->add_option("--command-period-ms", command_period_ms,
                  "the command node's timer period (the servo controller's tick_period_s): splits its stage into "
                  "the wait for the timer and the tick's own work")
      ->check(CLI::NonNegativeNumber);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  }

  try {
    const auto log = rt::read_log(log_path);
    if (info->parsed()) {
      info_opt.min_gap_us = static_cast<int64_t>(min_gap_s * 1e6);
      std::cout << format_info(log_path, log_info(log, info_opt));
      return 0;
    }
    if (lat->parsed()) {
      lat_opt.command_period_us = static_cast<int64_t>(std::llround(command_period_ms * 1000.0));
      const LatencyReport report = latency(log, lat_opt);
      std::cout << format_latency(log_path, report);
      if (!json_out.empty()) {
        std::ofstream f(json_out);
        if (!(f << latency_json(log_path, report))) throw std::runtime_error("cannot write " + json_out);
      }
      return 0;
    }
    if (exp->parsed()) {
      ExportOptions o;
      o.format = format == "jsonl" ? ExportFormat::kJsonl : ExportFormat::kCsv;
      o.fields = fields;
      o.problems = &std::cerr;
      if (out_file.empty()) {
        export_channel(log, channel, o, std::cout);
      } else {
        std::ofstream f(out_file);
        if (!f) throw std::runtime_error("cannot write " + out_file);
        const auto n = export_channel(log, channel, o, f);
        std::cerr << "harvest-log: " << n << " messages of " << channel << " -> " << out_file << "\n";
      }
      return 0;
    }
    FramesOptions o;
    o.image_channel = channel;
    o.detections_channel = detections;
    o.out_dir = out_dir;
    o.every = every;
    o.max = max_frames;
    o.sensor_size = sensor_size;
    o.format = frame_format;
    const auto written = write_frames(log, o, std::cerr);
    for (const auto& p : written) std::cout << p << "\n";
    return written.empty() ? 1 : 0;
  } catch (const std::exception& e) {
    std::cerr << "harvest-log: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace harvest::logtools
