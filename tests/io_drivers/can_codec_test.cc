// The DBC parser, the signal codec, the candump log format and the rig
// protocol bound to config/kc_rig.dbc.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "io_drivers/can_rig.h"
#include "io_drivers/dbc.h"
#include "io_drivers/kc_rig_protocol.h"
#include "records/can_log_decoder.h"
#include "records/internal/candump_log.h"

namespace kcrig {
namespace {

const std::string kDbcPath = std::string(KCRIG_TEST_CONFIG_DIR) + "/kc_rig.dbc";

Dbc LoadRigDbc() {
  Dbc dbc;
  const Status status = LoadDbc(kDbcPath, &dbc);
  EXPECT_TRUE(status.ok()) << status.message();
  return dbc;
}

TEST(DbcTest, RigDbcHasTheProtocolWithTheIssuesResolution) {
  const Dbc dbc = LoadRigDbc();
  EXPECT_EQ(dbc.version, "kcrig 1");
  ASSERT_EQ(dbc.messages.size(), 8u);
  EXPECT_EQ(dbc.nodes, (std::vector<std::string>{"Controller", "Rig"}));
  const DbcMessage* command = dbc.FindMessage("KC_Command");
  ASSERT_NE(command, nullptr);
  EXPECT_EQ(command->id, 0x100u);
  EXPECT_EQ(command->sender, "Controller");
  // Resolution at least 1 um, 1 urad, 0.5 N; ranges beyond the rig's
  // travel (0.05 m), angle (10 deg) and force (5 kN) limits.
  for (const char* name : {"X", "Y"}) {
    const DbcSignal* s = dbc.FindMessage("KC_PositionXY")->FindSignal(name);
    ASSERT_NE(s, nullptr);
    EXPECT_LE(s->factor, 1e-6);
    EXPECT_GE(s->highest, 0.05);
    EXPECT_LE(s->lowest, -0.05);
  }
  const DbcSignal* toe = dbc.FindMessage("KC_PositionZToe")->FindSignal("Toe");
  EXPECT_LE(toe->factor, 1e-6);
  EXPECT_GE(toe->highest, 10 * M_PI / 180);
  const DbcSignal* fx = dbc.FindMessage("KC_Force")->FindSignal("Fx");
  EXPECT_LE(fx->factor, 0.5);
  EXPECT_GE(fx->highest, 5000);
  const DbcSignal* sample =
      dbc.FindMessage("KC_Heartbeat")->FindSignal("SampleCounter");
  EXPECT_FALSE(sample->little_endian);
  EXPECT_EQ(sample->length, 32);
}

TEST(DbcTest, HeartbeatBytesMatchCanmatrix) {
  // canmatrix 0.9 encodes KC_Heartbeat {Status 1, FaultCode 0, Protocol 1,
  // SampleCounter 0x01020304} from config/kc_rig.dbc as 0100010102030400.
  const Dbc dbc = LoadRigDbc();
  const DbcMessage& m = *dbc.FindMessage("KC_Heartbeat");
  std::uint8_t data[8] = {};
  bool flagged = false;
  EncodeSignal(*m.FindSignal("Status"), 1, data, &flagged);
  EncodeSignal(*m.FindSignal("FaultCode"), 0, data, &flagged);
  EncodeSignal(*m.FindSignal("Protocol"), 1, data, &flagged);
  EncodeSignal(*m.FindSignal("SampleCounter"), 0x01020304, data, &flagged);
  const std::uint8_t expected[8] = {0x01, 0x00, 0x01, 0x01,
                                    0x02, 0x03, 0x04, 0x00};
  for (int k = 0; k < 8; ++k) EXPECT_EQ(data[k], expected[k]) << k;
  EXPECT_FALSE(flagged);
  EXPECT_EQ(DecodeSignal(*m.FindSignal("SampleCounter"), data, &flagged),
            0x01020304);
}

// Reference bit layout, written the way the DBC format describes it: Intel
// signals count up from the start bit (LSB); Motorola ones start at the MSB
// and walk the sawtooth (bit 7 of a byte follows bit 0 of the previous
// byte... of the next byte).
std::uint64_t ReferenceRaw(const DbcSignal& s, const std::uint8_t* data) {
  std::uint64_t raw = 0;
  int pos = s.start_bit;
  for (int k = 0; k < s.length; ++k) {
    const int bit = (data[pos / 8] >> (pos % 8)) & 1;
    if (s.little_endian) {
      raw |= static_cast<std::uint64_t>(bit) << k;
      ++pos;
    } else {
      raw = (raw << 1) | static_cast<std::uint64_t>(bit);
      pos = pos % 8 == 0 ? pos + 15 : pos - 1;
    }
  }
  return raw;
}

TEST(DbcTest, CodecAgreesWithTheBitByBitReferenceForAnyLayout) {
  std::mt19937 rng(7);
  int checked = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const bool little = rng() % 2 == 0;
    const int length = 1 + static_cast<int>(rng() % 64);
    const int start = static_cast<int>(rng() % 64);
    const bool is_signed = rng() % 2 == 0;
    const std::string text = "BO_ 1 M: 8 N\n SG_ S : " + std::to_string(start) +
                             "|" + std::to_string(length) + "@" +
                             (little ? "1" : "0") + (is_signed ? "-" : "+") +
                             " (1,0) [0|0] \"\" N\n";
    Dbc dbc;
    if (!ParseDbc(text, "t.dbc", &dbc).ok()) continue;  // does not fit
    const DbcSignal& s = dbc.messages[0].signals[0];
    std::uint8_t data[8];
    for (auto& b : data) b = static_cast<std::uint8_t>(rng());
    std::uint64_t raw = ReferenceRaw(s, data);
    bool flagged = false;
    const double value = DecodeSignal(s, data, &flagged);
    double expected = static_cast<double>(raw);
    if (is_signed && length < 64 && (raw >> (length - 1))) {
      expected = static_cast<double>(static_cast<std::int64_t>(raw) -
                                     (std::int64_t{1} << length));
    } else if (is_signed && length == 64) {
      expected = static_cast<double>(static_cast<std::int64_t>(raw));
    }
    ASSERT_EQ(value, expected) << text;
    // Encoding writes exactly those bits and leaves the others alone.
    if (length <= 52) {
      std::uint8_t copy[8];
      std::copy(data, data + 8, copy);
      EncodeSignal(s, value, copy, &flagged);
      for (int k = 0; k < 8; ++k) ASSERT_EQ(copy[k], data[k]) << text;
      const double other = is_signed ? -1 : 1;
      EncodeSignal(s, other, copy, &flagged);
      EXPECT_EQ(DecodeSignal(s, copy, &flagged), other);
    }
    EXPECT_FALSE(flagged);
    ++checked;
  }
  EXPECT_GT(checked, 500);
}

TEST(DbcTest, OutOfRangeIsClampedAndFlaggedNeverWrapped) {
  const Dbc dbc = LoadRigDbc();
  const DbcSignal& fx = *dbc.FindMessage("KC_Command")->FindSignal("Fx_Set");
  for (double value : {20000.0, -1e9, HUGE_VAL}) {
    std::uint8_t data[8] = {};
    bool flagged = false;
    EncodeSignal(fx, value, data, &flagged);
    EXPECT_TRUE(flagged) << value;
    bool decode_flag = false;
    EXPECT_EQ(DecodeSignal(fx, data, &decode_flag), value > 0 ? 16000 : -16000);
    EXPECT_FALSE(decode_flag);
  }
  std::uint8_t data[8] = {};
  bool flagged = false;
  EncodeSignal(fx, std::nan(""), data, &flagged);
  EXPECT_TRUE(flagged);
  EXPECT_EQ(DecodeSignal(fx, data, &flagged), 0);
  // Raw bits beyond the DBC range (int24 at 1 um holds +-8.4 m; the range
  // is +-1 m): decoded clamped and flagged.
  const DbcSignal& x = *dbc.FindMessage("KC_PositionXY")->FindSignal("X");
  std::uint8_t far[8] = {0xFF, 0xFF, 0x7F, 0, 0, 0, 0, 0};
  bool far_flag = false;
  EXPECT_EQ(DecodeSignal(x, far, &far_flag), 1.0);
  EXPECT_TRUE(far_flag);
  // Within range: the nearest step.
  std::uint8_t near[8] = {};
  bool near_flag = false;
  EncodeSignal(x, 0.0123456789, near, &near_flag);
  EXPECT_NEAR(DecodeSignal(x, near, &near_flag), 0.0123456789, 0.5e-6);
  EXPECT_FALSE(near_flag);
}

struct BadDbc {
  const char* text;
  const char* message;
};

TEST(DbcTest, MalformedFilesGetOneLineErrorsWithTheLine) {
  const BadDbc cases[] = {
      {"BO_ 1 M: 9 N\n", "t.dbc:1: message M: DLC 9 (CAN FD)"},
      {"BO_ 2048 M: 8 N\n", "t.dbc:1: message M: id 2048 is out of range"},
      {"BO_ 1 M: 8 N\n SG_ A : 60|8@1+ (1,0) [0|0] \"\" N\n",
       "t.dbc:2: signal M.A: bits 60..67 do not fit in 8 bytes"},
      {"BO_ 1 M: 8 N\n SG_ A : 0|8@1+ (1,0) [0|0] \"\" N\n"
       " SG_ B : 4|8@1+ (1,0) [0|0] \"\" N\n",
       "signal B overlaps another signal"},
      {"BO_ 1 M: 8 N\n SG_ A : 0|8@1+ (0,0) [0|0] \"\" N\n", "factor is zero"},
      {"BO_ 1 M: 8 N\n SG_ A M : 0|8@1+ (1,0) [0|0] \"\" N\n",
       "multiplexed signals are not supported"},
      {"BO_ 1 M: 8 N\nSIG_VALTYPE_ 1 A : 1;\n", "IEEE float signals"},
      {"CM_ \"never closed\n", "t.dbc:1: string not terminated"},
      {"CM_ BO_ 1 \"text\"\nBO_ 1 M: 8 N\n", "CM_ statement is not ended"},
      {"BO_ 1 M: 8 N\nBO_ 1 K: 8 N\n", "id 1 is defined twice"},
      {"BO_ 1 M: 8 N\n SG_ A : x|8@1+ (1,0) [0|0] \"\" N\n",
       "t.dbc:2: start bit 'x' is not an integer"},
      {"BO_ 1 M: 8 N\n SG_ A : 0|8@2+ (1,0) [0|0] \"\" N\n", "byte order '2'"},
      {"BO_ 1 M: 8 N\n SG_ A : 0|8@1+ (1,0) [5|1] \"\" N\n",
       "minimum is above maximum"},
      {"BO_ 1 M: 8 N\n SG_ A : 0|8@1+ (1,0) [300|400] \"\" N\n",
       "lies outside what 8 bits can hold"},
      {"SG_ A : 0|8@1+ (1,0) [0|0] \"\" N\n", "t.dbc:1: SG_ before any BO_"},
      {"BO_ 1 M: 8 N\n SG_ A : 0|8@1+ (1e999,0) [0|0] \"\" N\n",
       "factor '1e999' is not a finite number"},
      {"} BO_", "t.dbc:1: expected a keyword"},
  };
  for (const BadDbc& c : cases) {
    Dbc dbc;
    const Status status = ParseDbc(c.text, "t.dbc", &dbc);
    ASSERT_FALSE(status.ok()) << c.text;
    EXPECT_NE(status.message().find(c.message), std::string::npos)
        << status.message();
    EXPECT_EQ(status.message().find('\n'), std::string::npos);
  }
  Dbc dbc;
  EXPECT_NE(LoadDbc("/nonexistent.dbc", &dbc).message().find("cannot open"),
            std::string::npos);
}

TEST(DbcTest, AnnotationsAndIndependentSignalsAreReadOver) {
  const char* text =
      "VERSION \"\"\nNS_ :\n\tCM_\n\tBA_\nBS_:\nBU_: A B\n"
      "VAL_TABLE_ T 1 \"one\" 0 \"zero\" ;\n"
      "BO_ 3221225472 VECTOR__INDEPENDENT_SIG_MSG: 0 Vector__XXX\n"
      " SG_ Lost : 0|8@1+ (1,0) [0|0] \"\" Vector__XXX\n"
      "BO_ 2147483905 Ext: 4 A\n SG_ S : 7|16@0- (0.1,-5) [0|0] \"V\" B,A\n"
      "CM_ SG_ 2147483905 S \"multi\nline; with semicolon\";\n"
      "BA_DEF_ BO_ \"GenMsgCycleTime\" INT 0 100;\n";
  Dbc dbc;
  const Status status = ParseDbc(text, "t.dbc", &dbc);
  ASSERT_TRUE(status.ok()) << status.message();
  ASSERT_EQ(dbc.messages.size(), 1u);
  const DbcMessage& m = dbc.messages[0];
  EXPECT_TRUE(m.extended);
  EXPECT_EQ(m.id, 0x101u);
  ASSERT_EQ(m.signals.size(), 1u);
  EXPECT_EQ(m.signals[0].receivers, (std::vector<std::string>{"B", "A"}));
  EXPECT_EQ(m.signals[0].unit, "V");
  const std::uint8_t data[8] = {0xFF, 0xFE, 0, 0, 0, 0, 0, 0};  // raw -2
  bool flagged = false;
  EXPECT_NEAR(DecodeSignal(m.signals[0], data, &flagged), -5.2, 1e-12);
}

TEST(CandumpLogTest, LinesAsCanUtilsWritesThem) {
  CandumpRecord record;
  ASSERT_TRUE(
      ParseCandumpLine("(1436509052.249713) vcan0 044#2A366C2A", "x", &record)
          .ok());
  EXPECT_EQ(record.interface, "vcan0");
  EXPECT_EQ(record.frame.time_us, 1436509052249713);
  EXPECT_EQ(record.frame.frame.id, 0x44u);
  EXPECT_EQ(record.frame.frame.dlc, 4);
  EXPECT_EQ(record.frame.frame.data[3], 0x2A);
  char line[kCandumpLineMax];
  const size_t n = FormatCandumpLine(record.frame, "vcan0", line);
  EXPECT_EQ(std::string(line, n), "(1436509052.249713) vcan0 044#2A366C2A\n");

  const char* round_trips[] = {
      "(0000000001.000001) can0 1FFFFFFF#0011223344556677",
      "(1700000000.500000) vcan0 20000040#0000000000000000",  // bus-off
      "(1700000000.000000) vcan0 123#R", "(1700000000.000000) vcan0 123#R3",
      "(1700000000.000000) vcan0 7FF#"};
  for (const char* text : round_trips) {
    ASSERT_TRUE(ParseCandumpLine(text, "x", &record).ok()) << text;
    const size_t length =
        FormatCandumpLine(record.frame, record.interface, line);
    EXPECT_EQ(std::string(line, length), std::string(text) + "\n");
  }
  ASSERT_TRUE(
      ParseCandumpLine("(1700000000.500000) vcan0 20000040#0000000000000000",
                       "x", &record)
          .ok());
  EXPECT_TRUE(record.frame.frame.error);
  EXPECT_EQ(record.frame.frame.id, 0x40u);

  const std::string_view bad[] = {
      "", "1436509052.249713 vcan0 044#2A", "(1436509052.2497) vcan0 044#2A",
      "(1436509052.249713) vcan0 44#2A", "(1436509052.249713) vcan0 800#2A",
      "(1436509052.249713) vcan0 044#2A3", "(1436509052.249713) vcan0 044#2G",
      "(1436509052.249713) vcan0 044#001122334455667788",
      "(1436509052.249713) vcan0 044##1020304", "(1436509052.249713) vcan0",
      // Found by the candump fuzzer: a NUL in the name.
      std::string_view("(1436509052.249713) vc\0n0 044#2A", 33)};
  for (const std::string_view text : bad) {
    const Status status = ParseCandumpLine(text, "can.log:3", &record);
    EXPECT_FALSE(status.ok()) << text;
    EXPECT_EQ(status.message().rfind("can.log:3: ", 0), 0u) << status.message();
  }
}

class RigProtocolTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dbc_ = LoadRigDbc();
    const Status status = protocol_.Bind(dbc_, kDbcPath);
    ASSERT_TRUE(status.ok()) << status.message();
  }

  RigMeasurement Sample(std::uint32_t number) {
    RigMeasurement m;
    m.sample = number;
    m.force << 1234.56, -4321.1, 250.25;
    m.y << 0.0123456, -0.004321, 0.045, 0.01234567, -0.0872, 0.1745;
    m.status = kRigEnabled;
    return m;
  }

  Dbc dbc_;
  KcRigProtocol protocol_;
};

TEST_F(RigProtocolTest, SampleRoundTripsToTheDbcResolution) {
  CanFrame frames[kSampleFrames];
  bool flagged = false;
  protocol_.EncodeSample(Sample(300), frames, &flagged);
  EXPECT_FALSE(flagged);
  KcSampleAssembler assembler(&protocol_);
  RigMeasurement decoded;
  for (int f = 0; f < kSampleFrames; ++f) {
    const KcFrame kind = protocol_.Classify(frames[f]);
    ASSERT_TRUE(protocol_.WellFormed(frames[f], kind));
    EXPECT_EQ(assembler.Add(frames[f], kind, &decoded), f == kSampleFrames - 1);
  }
  const RigMeasurement m = Sample(300);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(decoded.force(k), m.force(k), 0.25);
  for (int k = 0; k < 6; ++k) EXPECT_NEAR(decoded.y(k), m.y(k), 0.5e-6);
  EXPECT_EQ(decoded.status, kRigEnabled);
  EXPECT_EQ(decoded.sample, 300u & 0xFF);  // the first sample: the counter
}

TEST_F(RigProtocolTest, CommandSetupSessionAndHeartbeatRoundTrip) {
  KcCommand command;
  command.force << -4999.5, 0.5, 12000;
  command.sequence = 201;
  command.enable = true;
  command.session = kMaxCanSession;
  bool flagged = false;
  const CanFrame frame = protocol_.EncodeCommand(command, &flagged);
  EXPECT_FALSE(flagged);
  EXPECT_EQ(frame.id, 0x100u);
  const KcCommand back = protocol_.DecodeCommand(frame, &flagged);
  EXPECT_EQ(back.force, command.force);
  EXPECT_EQ(back.sequence, 201);
  EXPECT_TRUE(back.enable);
  EXPECT_EQ(back.session, kMaxCanSession);
  const KcSetup setup{-0.45, 1e-3, kKcRigProtocolVersion, 5, 1};
  const KcSetup setup_back =
      protocol_.DecodeSetup(protocol_.EncodeSetup(setup, &flagged), &flagged);
  EXPECT_NEAR(setup_back.z_a, -0.45, 1e-9);
  EXPECT_NEAR(setup_back.period, 1e-3, 1e-12);
  EXPECT_EQ(setup_back.protocol, kKcRigProtocolVersion);
  EXPECT_EQ(setup_back.phase, 5);
  EXPECT_EQ(setup_back.safety, 1);
  EXPECT_FALSE(flagged);
  for (const KcSession session :
       {KcSession{42, true, false, true}, KcSession{1, false, true, false}}) {
    const CanFrame encoded = protocol_.EncodeSession(session);
    EXPECT_EQ(encoded.id, 0x102u);
    const KcSession decoded = protocol_.DecodeSession(encoded);
    EXPECT_EQ(decoded.session, session.session);
    EXPECT_EQ(decoded.claim, session.claim);
    EXPECT_EQ(decoded.release, session.release);
    EXPECT_EQ(decoded.reset_fault, session.reset_fault);
  }
  KcHeartbeat heartbeat;
  heartbeat.status = 1;
  heartbeat.protocol = kKcRigProtocolVersion;
  heartbeat.sample = 0xFFFFFFFFu;
  heartbeat.owner = 99;
  heartbeat.refusing = true;
  const KcHeartbeat heartbeat_back =
      protocol_.DecodeHeartbeat(protocol_.EncodeHeartbeat(heartbeat));
  EXPECT_EQ(heartbeat_back.sample, 0xFFFFFFFFu);
  EXPECT_EQ(heartbeat_back.owner, 99);
  EXPECT_TRUE(heartbeat_back.refusing);
}

// The offline reader names each cycle's phase from the last KC_Setup, keeps
// the claiming session's commands only, and refuses a log of another
// protocol version in one line.
TEST_F(RigProtocolTest, DecodedRowsFollowTheSetupAndTheClaimingSession) {
  const std::string path =
      (std::filesystem::temp_directory_path() /
       ("kcrig_phases_" + std::to_string(::getpid()) + ".log"))
          .string();
  struct Cycle {
    int phase;
    int session;
  };
  auto decode = [&](int version, const std::vector<Cycle>& cycles, RunLog* log,
                    CanLogCounts* counts) {
    std::ofstream out(path);
    char line[kCandumpLineMax];
    bool flagged = false;
    std::int64_t t = 1000000;
    auto write = [&](const CanFrame& frame) {
      out.write(line, FormatCandumpLine({t += 1000, frame}, "vcan0", line));
    };
    write(protocol_.EncodeSession({7, true, false, true}));
    int phase = -1;
    for (size_t k = 0; k < cycles.size(); ++k) {
      if (cycles[k].phase != phase) {
        phase = cycles[k].phase;
        write(protocol_.EncodeSetup(
            {-0.45, 1e-3, version, static_cast<std::uint8_t>(phase), 0},
            &flagged));
      }
      KcCommand command;
      command.sequence = static_cast<std::uint8_t>(k);
      command.enable = true;
      command.session = static_cast<std::uint8_t>(cycles[k].session);
      write(protocol_.EncodeCommand(command, &flagged));
    }
    out.close();
    CanLogDecoderOptions options;
    options.dbc_file = kDbcPath;
    options.sigma_position = 2e-5;
    options.sigma_angle = 1.7e-4;
    return DecodeCanLog(path, options, log, counts);
  };
  RunLog log;
  CanLogCounts counts;
  const Status status =
      decode(kKcRigProtocolVersion,
             {{0, 7}, {4, 7}, {4, 9}, {5, 7}, {6, 7}, {7, 7}, {8, 7}, {9, 7}},
             &log, &counts);
  ASSERT_TRUE(status.ok()) << status.message();
  std::vector<std::string> names;
  for (const LogSample& s : log.samples) names.emplace_back(s.phase);
  // Cycle 2 is another session's (the rig refused it): a skipped cycle.
  EXPECT_EQ(names, (std::vector<std::string>{"ramp", "ramp", "hold", "return",
                                             "ramp_down", "done", "unknown"}));
  EXPECT_EQ(counts.commands, 6);
  EXPECT_EQ(counts.foreign, 1);
  const Status old = decode(2, {{4, 7}, {5, 7}}, &log, &counts);
  ASSERT_FALSE(old.ok());
  EXPECT_NE(old.message().find("a log of CAN protocol 2"), std::string::npos)
      << old.message();
  std::filesystem::remove(path);
}

TEST_F(RigProtocolTest, AssemblerCountsStaleOutOfSequenceAndIncomplete) {
  KcSampleAssembler assembler(&protocol_);
  auto feed = [&](std::uint32_t number, int first, int last) {
    CanFrame frames[kSampleFrames];
    bool flagged = false;
    protocol_.EncodeSample(Sample(number), frames, &flagged);
    RigMeasurement out;
    bool completed = false;
    for (int f = first; f <= last; ++f) {
      completed = assembler.Add(frames[f], protocol_.Classify(frames[f]), &out);
    }
    return completed ? static_cast<std::int64_t>(out.sample) : -1;
  };
  EXPECT_EQ(feed(250, 0, 3), 250);
  EXPECT_EQ(feed(250, 0, 3), -1);  // the same sample again: stale
  EXPECT_EQ(assembler.stale(), 4);
  EXPECT_EQ(feed(251, 0, 1), -1);   // half a sample ...
  EXPECT_EQ(feed(253, 0, 3), 253);  // ... abandoned for a newer one
  EXPECT_EQ(assembler.incomplete(), 1);
  EXPECT_EQ(feed(252, 0, 3), -1);  // behind: out of sequence
  EXPECT_EQ(assembler.out_of_sequence(), 4);
  // The counter wraps at 256; the sample number goes on.
  EXPECT_EQ(feed(254, 0, 3), 254);
  EXPECT_EQ(feed(255, 0, 3), 255);
  EXPECT_EQ(feed(256, 0, 3), 256);
  EXPECT_EQ(feed(260, 0, 3), 260);
}

TEST(CanErrorFaultTest, BusOffErrorPassiveAndTxTimeoutAreFaultsOthersNot) {
  auto error_frame = [](std::uint32_t classes, std::uint8_t controller) {
    CanFrame f;
    f.error = true;
    f.id = classes;
    f.dlc = 8;
    f.data[1] = controller;
    return f;
  };
  // linux/can/error.h: TX_TIMEOUT 0x1, CRTL 0x4, PROT 0x8, ACK 0x20,
  // BUSOFF 0x40; data[1]: RX_WARNING 0x4, TX_WARNING 0x8, RX_PASSIVE 0x10,
  // TX_PASSIVE 0x20.
  EXPECT_STREQ(CanErrorFault(error_frame(0x40, 0)), "CAN bus-off");
  EXPECT_STREQ(CanErrorFault(error_frame(0x01, 0)), "CAN tx timeout");
  EXPECT_STREQ(CanErrorFault(error_frame(0x04, 0x10)), "CAN error-passive");
  EXPECT_STREQ(CanErrorFault(error_frame(0x04, 0x20)), "CAN error-passive");
  EXPECT_EQ(CanErrorFault(error_frame(0x04, 0x0C)), nullptr);  // warning
  EXPECT_EQ(CanErrorFault(error_frame(0x08, 0)), nullptr);     // protocol
  EXPECT_EQ(CanErrorFault(error_frame(0x20, 0)), nullptr);     // no ACK
  CanFrame data_frame;
  data_frame.id = 0x40;
  EXPECT_EQ(CanErrorFault(data_frame), nullptr);
}

TEST_F(RigProtocolTest, BindRefusesAnotherDatabase) {
  Dbc other;
  ASSERT_TRUE(ParseDbc("BO_ 256 KC_Command: 8 C\n", "o.dbc", &other).ok());
  KcRigProtocol protocol;
  const Status status = protocol.Bind(other, "o.dbc");
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("o.dbc: no message KC_Setup"),
            std::string::npos)
      << status.message();
}

}  // namespace
}  // namespace kcrig
