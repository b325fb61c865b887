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

// Serial protocol of the SMA actuator MCU: COBS framing, CRC-32 and messages.
//
// C++ twin of sma_actuator/hardware/protocol.py; both are checked byte-for-byte against
// firmware/test_vectors.json. Specification: docs/protocol.md.
//
//   wire frame = COBS(payload) 0x00
//   payload    = type:u8 seq:u8 body crc:u32le   (at most 64 bytes)
//   crc        = CRC-32/ISO-HDLC (same as zlib.crc32) over type, seq and body
//
// Portable C++ (no Arduino API, no heap, no STL) so that the host compiles and tests it.
#ifndef SMA_PROTOCOL_H
#define SMA_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

namespace sma {

const uint8_t kProtocolVersion = 1;
const uint16_t kDutyFullScale = 65535;  // duty counts meaning 100 %
const size_t kMaxPayload = 64;          // type + seq + body + crc, before COBS
const size_t kMaxEncoded = kMaxPayload + 1;
const size_t kMaxWireFrame = kMaxEncoded + 1;  // with the 0x00 delimiter
const size_t kHeaderSize = 2;
const size_t kCrcSize = 4;
const size_t kMinPayload = kHeaderSize + kCrcSize;

enum MsgType : uint8_t {
  kHello = 0x01, kDuty = 0x02, kHeartbeat = 0x03,  // host -> MCU
  kHelloAck = 0x81, kAdcReport = 0x82, kHeartbeatAck = 0x83, kStatus = 0x84,  // MCU -> host
};

enum Fault : uint16_t {
  kFaultWatchdog = 1u << 0,       // no valid Duty frame for the watchdog time: outputs off
  kFaultInterlock = 1u << 1,      // last Duty asked for heat the dead-time interlock holds off
  kFaultRejected = 1u << 2,       // last Duty exceeded max_duty: ignored, outputs unchanged
  kFaultNotConfigured = 1u << 3,  // no valid Hello since reset: Duty ignored
  kFaultBadVersion = 1u << 4,     // last Hello asked for an unsupported protocol version
};

// CRC-32/ISO-HDLC of data (check value of "123456789" is 0xCBF43926).
uint32_t crc32(const uint8_t* data, size_t len);

// COBS-encodes len bytes into out (capacity >= len + len / 254 + 1); returns the length.
size_t cobs_encode(const uint8_t* in, size_t len, uint8_t* out);

// COBS-decodes; false if malformed (zero byte, or a code running past the end).
// out needs capacity >= len; *out_len receives the decoded length.
bool cobs_decode(const uint8_t* in, size_t len, uint8_t* out, size_t* out_len);

// Builds a complete wire frame (COBS + delimiter) into out (capacity >= kMaxWireFrame).
// Returns its length, or 0 if the body does not fit the payload limit.
size_t encode_frame(uint8_t type, uint8_t seq, const uint8_t* body, size_t body_len, uint8_t* out);

enum DecodeResult : uint8_t { kNone, kFrameOk, kErrOversize, kErrCobs, kErrShort, kErrCrc };

// Byte-wise stream decoder: push() every received byte; on kFrameOk the frame is
// available through type()/seq()/body() until the next push(). A bad chunk costs only
// itself: decoding restarts after the next 0x00.
class FrameDecoder {
 public:
  FrameDecoder();
  DecodeResult push(uint8_t byte);
  void reset();
  uint8_t type() const { return payload_[0]; }
  uint8_t seq() const { return payload_[1]; }
  const uint8_t* body() const { return payload_ + kHeaderSize; }
  size_t body_len() const { return payload_len_ - kMinPayload; }

 private:
  DecodeResult finish_chunk();
  uint8_t chunk_[kMaxEncoded];
  size_t chunk_len_;
  bool discarding_;  // inside an oversize run: drop bytes up to the next 0x00
  uint8_t payload_[kMaxPayload];
  size_t payload_len_;
};

// --- messages (all integers little-endian) -----------------------------------------

struct Hello { uint8_t protocol_version; uint16_t max_duty; uint16_t interlock_duty; uint32_t adc_period_us; };
struct Duty { uint16_t duty_a; uint16_t duty_b; };
struct Heartbeat { uint32_t host_us; };
struct HelloAck {
  uint8_t protocol_version, fw_major, fw_minor, fw_patch;
  uint32_t tick_hz;
  uint8_t adc_bits;
  uint16_t watchdog_ms, max_duty, interlock_duty;
  uint32_t adc_period_us;
};
struct AdcReport { uint32_t ticks_us; uint16_t counts; uint8_t duty_seq; uint16_t faults, duty_a, duty_b; };
struct HeartbeatAck { uint32_t host_us, ticks_us; };
struct Status {
  uint32_t ticks_us;
  uint16_t faults, faults_latched;
  uint32_t rx_frames, rx_crc_errors, rx_framing_errors, rx_malformed;
};

// Body parsers: false if the body has the wrong size.
bool decode(const uint8_t* body, size_t len, Hello* msg);
bool decode(const uint8_t* body, size_t len, Duty* msg);
bool decode(const uint8_t* body, size_t len, Heartbeat* msg);

// Wire-frame builders (out capacity >= kMaxWireFrame); return the frame length.
size_t encode(const HelloAck& msg, uint8_t seq, uint8_t* out);
size_t encode(const AdcReport& msg, uint8_t seq, uint8_t* out);
size_t encode(const HeartbeatAck& msg, uint8_t seq, uint8_t* out);
size_t encode(const Status& msg, uint8_t seq, uint8_t* out);

}  // namespace sma

#endif  // SMA_PROTOCOL_H
