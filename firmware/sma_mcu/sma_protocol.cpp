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

// Serial protocol of the SMA actuator MCU; see sma_protocol.h and docs/protocol.md.
#include "sma_protocol.h"

#include <string.h>

namespace sma {

namespace {

// Nibble table of the reflected CRC-32 polynomial 0xEDB88320: 64 bytes of table instead
// of 1 KiB, about 4x faster than bit-by-bit (matters on an 8-bit MCU at 16 MHz).
const uint32_t kCrcNibble[16] = {
  0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u, 0x4DB26158u, 0x5005713Cu,
  0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu, 0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu,
};

void put16(uint8_t* p, uint16_t v) { p[0] = v & 0xFF; p[1] = v >> 8; }
void put32(uint8_t* p, uint32_t v) { put16(p, v & 0xFFFF); put16(p + 2, v >> 16); }
uint16_t get16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
uint32_t get32(const uint8_t* p) { return get16(p) | (static_cast<uint32_t>(get16(p + 2)) << 16); }

}  // namespace

uint32_t crc32(const uint8_t* data, size_t len) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < len; ++i) {
    crc ^= data[i];
    crc = kCrcNibble[crc & 0x0F] ^ (crc >> 4);
    crc = kCrcNibble[crc & 0x0F] ^ (crc >> 4);
  }
  return crc ^ 0xFFFFFFFFu;
}

size_t cobs_encode(const uint8_t* in, size_t len, uint8_t* out) {
  size_t code_at = 0;  // where the current block's code byte goes
  size_t n = 1;
  uint8_t code = 1;
  for (size_t i = 0; i < len; ++i) {
    if (in[i] == 0) {
      out[code_at] = code;
      code_at = n++;
      code = 1;
      continue;
    }
    out[n++] = in[i];
    if (++code == 0xFF) {
      out[code_at] = code;
      code = 1;
      if (i + 1 == len) return n;  // a final full block needs no trailing 0x01 code
      code_at = n++;
    }
  }
  out[code_at] = code;
  return n;
}

bool cobs_decode(const uint8_t* in, size_t len, uint8_t* out, size_t* out_len) {
  size_t i = 0, n = 0;
  while (i < len) {
    uint8_t code = in[i];
    if (code == 0 || i + code > len) return false;
    for (size_t k = i + 1; k < i + code; ++k) {
      if (in[k] == 0) return false;
      out[n++] = in[k];
    }
    i += code;
    if (code != 0xFF && i < len) out[n++] = 0;
  }
  *out_len = n;
  return true;
}

size_t encode_frame(uint8_t type, uint8_t seq, const uint8_t* body, size_t body_len, uint8_t* out) {
  if (body_len + kMinPayload > kMaxPayload) return 0;
  uint8_t payload[kMaxPayload];
  payload[0] = type;
  payload[1] = seq;
  memcpy(payload + kHeaderSize, body, body_len);
  size_t len = kHeaderSize + body_len;
  put32(payload + len, crc32(payload, len));
  len += kCrcSize;
  size_t n = cobs_encode(payload, len, out);
  out[n++] = 0;
  return n;
}

FrameDecoder::FrameDecoder() { reset(); }

void FrameDecoder::reset() {
  chunk_len_ = 0;
  discarding_ = false;
  payload_len_ = 0;
}

DecodeResult FrameDecoder::push(uint8_t byte) {
  if (byte == 0) {
    if (discarding_) {
      discarding_ = false;
      return kNone;
    }
    if (chunk_len_ == 0) return kNone;  // repeated delimiters flush the line, not an error
    DecodeResult result = finish_chunk();
    chunk_len_ = 0;
    return result;
  }
  if (discarding_) return kNone;
  if (chunk_len_ == kMaxEncoded) {
    discarding_ = true;
    chunk_len_ = 0;
    return kErrOversize;
  }
  chunk_[chunk_len_++] = byte;
  return kNone;
}

DecodeResult FrameDecoder::finish_chunk() {
  size_t len = 0;
  if (!cobs_decode(chunk_, chunk_len_, payload_, &len)) return kErrCobs;
  if (len < kMinPayload) return kErrShort;
  if (crc32(payload_, len - kCrcSize) != get32(payload_ + len - kCrcSize)) return kErrCrc;
  payload_len_ = len;
  return kFrameOk;
}

bool decode(const uint8_t* b, size_t len, Hello* m) {
  if (len != 9) return false;
  m->protocol_version = b[0];
  m->max_duty = get16(b + 1);
  m->interlock_duty = get16(b + 3);
  m->adc_period_us = get32(b + 5);
  return true;
}

bool decode(const uint8_t* b, size_t len, Duty* m) {
  if (len != 4) return false;
  m->duty_a = get16(b);
  m->duty_b = get16(b + 2);
  return true;
}

bool decode(const uint8_t* b, size_t len, Heartbeat* m) {
  if (len != 4) return false;
  m->host_us = get32(b);
  return true;
}

size_t encode(const HelloAck& m, uint8_t seq, uint8_t* out) {
  uint8_t b[19];
  b[0] = m.protocol_version;
  b[1] = m.fw_major;
  b[2] = m.fw_minor;
  b[3] = m.fw_patch;
  put32(b + 4, m.tick_hz);
  b[8] = m.adc_bits;
  put16(b + 9, m.watchdog_ms);
  put16(b + 11, m.max_duty);
  put16(b + 13, m.interlock_duty);
  put32(b + 15, m.adc_period_us);
  return encode_frame(kHelloAck, seq, b, sizeof(b), out);
}

size_t encode(const AdcReport& m, uint8_t seq, uint8_t* out) {
  uint8_t b[13];
  put32(b, m.ticks_us);
  put16(b + 4, m.counts);
  b[6] = m.duty_seq;
  put16(b + 7, m.faults);
  put16(b + 9, m.duty_a);
  put16(b + 11, m.duty_b);
  return encode_frame(kAdcReport, seq, b, sizeof(b), out);
}

size_t encode(const HeartbeatAck& m, uint8_t seq, uint8_t* out) {
  uint8_t b[8];
  put32(b, m.host_us);
  put32(b + 4, m.ticks_us);
  return encode_frame(kHeartbeatAck, seq, b, sizeof(b), out);
}

size_t encode(const Status& m, uint8_t seq, uint8_t* out) {
  uint8_t b[24];
  put32(b, m.ticks_us);
  put16(b + 4, m.faults);
  put16(b + 6, m.faults_latched);
  put32(b + 8, m.rx_frames);
  put32(b + 12, m.rx_crc_errors);
  put32(b + 16, m.rx_framing_errors);
  put32(b + 20, m.rx_malformed);
  return encode_frame(kStatus, seq, b, sizeof(b), out);
}

}  // namespace sma
