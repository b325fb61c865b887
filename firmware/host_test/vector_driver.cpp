// Copyright 2026 sma_actuator developers
//
// Licensed under the Apache License, Version 2.0 (the "License");
// you may not use this file except in compliance with the License.
// You may obtain a copy of the License at
//
//     http://www.apache.org/licenses/LICENSE-2.0
//
// Unless required by applicable law or agreed to in writing, software
// distributed under the License is distributed on an "AS IS" BASIS,
// WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
// See the License for the specific language governing permissions and
// limitations under the License.

// Host test driver: replays firmware/test_vectors.json against the firmware's C++ code.
//
//   vector_driver <test_vectors.json>   check every vector; prints failures and a summary,
//                                        exit status 1 if any vector fails
//   vector_driver --decode-stream        read hex lines on stdin, print the decoder events
//                                        of each (differential fuzzing against Python)
//
// The vectors file has one vector object per line with string values only (written by
// python test/support/firmware_vectors.py), so a tiny key lookup replaces a JSON parser.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "sma_mcu_core.h"
#include "sma_protocol.h"

using Bytes = std::vector<uint8_t>;

namespace {

std::string field(const std::string& line, const std::string& key) {
  const std::string tag = "\"" + key + "\": \"";
  size_t at = line.find(tag);
  if (at == std::string::npos) return "";
  at += tag.size();
  return line.substr(at, line.find('"', at) - at);
}

Bytes from_hex(const std::string& hex) {
  Bytes out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) out.push_back(std::stoi(hex.substr(i, 2), nullptr, 16));
  return out;
}

std::string to_hex(const uint8_t* data, size_t len) {
  static const char* digits = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < len; ++i) {
    out += digits[data[i] >> 4];
    out += digits[data[i] & 15];
  }
  return out;
}
std::string to_hex(const Bytes& b) { return to_hex(b.data(), b.size()); }

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, sep)) if (!item.empty()) out.push_back(item);
  return out;
}

std::string stream_events(const Bytes& data) {
  static const char* names[] = {"", "", "oversize", "cobs", "short", "crc"};
  sma::FrameDecoder decoder;
  std::string out;
  for (uint8_t byte : data) {
    sma::DecodeResult r = decoder.push(byte);
    if (r == sma::kNone) continue;
    if (!out.empty()) out += ' ';
    if (r == sma::kFrameOk) {
      Bytes payload = {decoder.type(), decoder.seq()};
      payload.insert(payload.end(), decoder.body(), decoder.body() + decoder.body_len());
      out += "F:" + to_hex(payload);
    } else {
      out += std::string("E:") + names[r];
    }
  }
  return out.empty() ? "-" : out;
}

// --- msg vectors: host->MCU types are decoded, MCU->host types encoded -----------------

std::string msg_vector(const std::string& type, const std::string& fields_text, const std::string& wire_hex) {
  std::map<std::string, uint32_t> f;
  for (const std::string& kv : split(fields_text, ' ')) {
    size_t eq = kv.find('=');
    f[kv.substr(0, eq)] = static_cast<uint32_t>(std::stoul(kv.substr(eq + 1)));
  }
  uint8_t seq = f["seq"];
  uint8_t out[sma::kMaxWireFrame];
  size_t n = 0;
  if (type == "HelloAck") {
    sma::HelloAck m = {uint8_t(f["protocol_version"]), uint8_t(f["fw_major"]), uint8_t(f["fw_minor"]),
                       uint8_t(f["fw_patch"]), f["tick_hz"], uint8_t(f["adc_bits"]), uint16_t(f["watchdog_ms"]),
                       uint16_t(f["max_duty"]), uint16_t(f["interlock_duty"]), f["adc_period_us"]};
    n = sma::encode(m, seq, out);
  } else if (type == "AdcReport") {
    sma::AdcReport m = {f["ticks_us"], uint16_t(f["counts"]), uint8_t(f["duty_seq"]), uint16_t(f["faults"]),
                        uint16_t(f["duty_a"]), uint16_t(f["duty_b"])};
    n = sma::encode(m, seq, out);
  } else if (type == "HeartbeatAck") {
    sma::HeartbeatAck m = {f["host_us"], f["ticks_us"]};
    n = sma::encode(m, seq, out);
  } else if (type == "Status") {
    sma::Status m = {f["ticks_us"], uint16_t(f["faults"]), uint16_t(f["faults_latched"]), f["rx_frames"],
                     f["rx_crc_errors"], f["rx_framing_errors"], f["rx_malformed"]};
    n = sma::encode(m, seq, out);
  } else {
    // Host -> MCU: decode the expected wire bytes and print the fields back.
    sma::FrameDecoder decoder;
    std::string text = "no frame";
    for (uint8_t byte : from_hex(wire_hex)) {
      if (decoder.push(byte) != sma::kFrameOk) continue;
      const uint8_t* b = decoder.body();
      size_t len = decoder.body_len();
      std::ostringstream s;
      s << "seq=" << unsigned(decoder.seq());
      sma::Hello h;
      sma::Duty d;
      sma::Heartbeat hb;
      if (type == "Hello" && decoder.type() == sma::kHello && sma::decode(b, len, &h)) {
        s << " protocol_version=" << unsigned(h.protocol_version) << " max_duty=" << h.max_duty
          << " interlock_duty=" << h.interlock_duty << " adc_period_us=" << h.adc_period_us;
      } else if (type == "Duty" && decoder.type() == sma::kDuty && sma::decode(b, len, &d)) {
        s << " duty_a=" << d.duty_a << " duty_b=" << d.duty_b;
      } else if (type == "Heartbeat" && decoder.type() == sma::kHeartbeat && sma::decode(b, len, &hb)) {
        s << " host_us=" << hb.host_us;
      } else {
        s << " undecodable";
      }
      text = s.str();
    }
    return text == fields_text ? wire_hex : "decoded as: " + text;
  }
  return to_hex(out, n);
}

// --- mcu scenarios ---------------------------------------------------------------------

struct Scenario {
  unsigned adc_reads = 0;
  Bytes tx;
};

uint16_t scenario_adc(void* ctx) {  // same sequence as vectors.scenario_adc()
  Scenario* s = static_cast<Scenario*>(ctx);
  return static_cast<uint16_t>((1000 + 37 * s->adc_reads++) % 4096);
}

void scenario_tx(const uint8_t* data, size_t len, void* ctx) {
  Bytes& tx = static_cast<Scenario*>(ctx)->tx;
  tx.insert(tx.end(), data, data + len);
}

std::string run_scenario(const std::string& steps) {
  Scenario s;
  sma::McuCore mcu(scenario_adc, scenario_tx, &s);
  std::string out;
  for (const std::string& step : split(steps, ' ')) {
    std::vector<std::string> parts = split(step, ':');
    uint32_t t = static_cast<uint32_t>(std::stoul(parts[1]));
    s.tx.clear();
    if (parts[0] == "S") {
      mcu.start(t);
    } else {
      if (parts[0] == "R") for (uint8_t byte : from_hex(parts[2])) mcu.receive(byte, t);
      mcu.poll(t);
    }
    if (!out.empty()) out += ' ';
    out += std::to_string(mcu.pwm_a()) + "," + std::to_string(mcu.pwm_b()) + "," + std::to_string(mcu.faults()) +
           "," + (s.tx.empty() ? "-" : to_hex(s.tx));
  }
  return out;
}

std::string run_vector(const std::string& kind, const std::string& line) {
  if (kind == "msg") return msg_vector(field(line, "type"), field(line, "in"), field(line, "out"));
  if (kind == "mcu") return run_scenario(field(line, "in"));
  Bytes in = from_hex(field(line, "in"));
  if (kind == "crc32") {
    char buf[9];
    std::snprintf(buf, sizeof(buf), "%08x", static_cast<unsigned>(sma::crc32(in.data(), in.size())));
    return buf;
  }
  if (kind == "cobs") {
    Bytes enc(in.size() + in.size() / 254 + 1), dec(in.size() + 1);
    size_t n = sma::cobs_encode(in.data(), in.size(), enc.data()), m = 0;
    enc.resize(n);
    if (!sma::cobs_decode(enc.data(), enc.size(), dec.data(), &m) || Bytes(dec.begin(), dec.begin() + m) != in) {
      return "round trip failed";
    }
    return to_hex(enc);
  }
  if (kind == "frame") {
    uint8_t out[sma::kMaxWireFrame];
    return to_hex(out, sma::encode_frame(in[0], in[1], in.data() + 2, in.size() - 2, out));
  }
  if (kind == "stream") return stream_events(in);
  return "unknown kind " + kind;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--decode-stream") {
    std::string line;
    while (std::getline(std::cin, line)) std::cout << stream_events(from_hex(line)) << '\n';
    return 0;
  }
  if (argc != 2) {
    std::cerr << "usage: vector_driver <test_vectors.json> | --decode-stream\n";
    return 2;
  }
  std::ifstream file(argv[1]);
  if (!file) {
    std::cerr << "cannot open " << argv[1] << '\n';
    return 2;
  }
  std::map<std::string, int> checked;
  int failed = 0, total = 0;
  std::string line;
  while (std::getline(file, line)) {
    std::string kind = field(line, "kind");
    if (kind.empty()) continue;
    ++total;
    ++checked[kind];
    std::string expected = field(line, "out"), got = run_vector(kind, line);
    if (got != expected) {
      ++failed;
      std::cout << "FAIL " << kind << " #" << total << ' ' << field(line, "name") << "\n  expected " << expected
                << "\n  got      " << got << '\n';
    }
  }
  for (const auto& kv : checked) std::cout << kv.first << '=' << kv.second << ' ';
  std::cout << "\nchecked " << total << " vectors, " << failed << " failed\n";
  return failed || total == 0 ? 1 : 0;
}
