// A drive's object dictionary from an electronic data sheet (CiA 306), written here by hand as a
// drive maker writes one: the values it holds, a DCF's configured values over the defaults, the
// node id in COB-IDs, and every malformed file refused with its file, line, section, key and value.
#include <gtest/gtest.h>

#include <string>

#include "hpr/hal/eds.hpp"

namespace {

using namespace hpr::hal::canopen;
using hpr::ConfigError;

const char* const kEds = R"(; a servo drive, CiA 402
[FileInfo]
FileName=servo.eds
FileVersion=1
CreatedBy=test

[DeviceInfo]
VendorName=Test
ProductName=Servo

[MandatoryObjects]
SupportedObjects=2
1=0x1000
2=0x1001

[1000]
ParameterName=Device type
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x00020192
PDOMapping=0

[1001]
ParameterName=Error register
DataType=0x0005
AccessType=ro
DefaultValue=0

[1400]
ParameterName=RPDO1 communication parameter
ObjectType=0x9
SubNumber=2

[1400sub0]
ParameterName=Highest sub-index supported
ObjectType=0x7
DataType=0x0005
AccessType=const
DefaultValue=2

[1400sub1]
ParameterName=COB-ID used by RPDO
ObjectType=0x7
DataType=0x0007
AccessType=rw
DefaultValue=$NODEID+0x200

[6040]
ParameterName=Controlword
ObjectType=0x7
DataType=0x0006
AccessType=rww
DefaultValue=0
PDOMapping=1

[6041]
ParameterName=Statusword
DataType=0x0006
AccessType=ro
PDOMapping=1

[6060]
ParameterName=Modes of operation
DataType=0x0002
AccessType=rw
DefaultValue=010
PDOMapping=1

[6071]
ParameterName=Target torque
DataType=0x0003
AccessType=rww
DefaultValue=-1
PDOMapping=1

[6076]
ParameterName=Motor rated torque
DataType=0x0007
AccessType=rw
DefaultValue=1200
ParameterValue=2500

[2000]
ParameterName=Torque constant
DataType=0x0008
AccessType=rw
DefaultValue=1.5
)";

TEST(Eds, TheObjectsADriveMakerWritesAndTheirValues) {
  const ObjectDictionary od = ObjectDictionary::parse(kEds, "servo.eds");
  EXPECT_EQ(od.size(), 10U) << "every VAR, not the record's header nor the file's other sections";
  const OdEntry* type = od.find(0x1000);
  ASSERT_NE(type, nullptr);
  EXPECT_EQ(type->name, "Device type");
  EXPECT_EQ(type->type, DataType::kUnsigned32);
  EXPECT_FALSE(type->writable());
  EXPECT_EQ(od.value(0x1000, 0, 1), 0x00020192U);
  EXPECT_EQ(od.value(0x1400, 1, 5), 0x205U) << "$NODEID+0x200 for node 5";
  EXPECT_EQ(od.value(0x1400, 0, 5), 2U);
  EXPECT_EQ(od.find(0x1400, 0)->access, Access::kConst);
  const OdEntry* cw = od.find(0x6040);
  ASSERT_NE(cw, nullptr);
  EXPECT_TRUE(cw->pdo_mappable);
  EXPECT_TRUE(cw->writable());
  EXPECT_EQ(cw->access, Access::kReadWriteOnWrite);
  EXPECT_FALSE(od.value(0x6041, 0, 1)) << "no default value";
  EXPECT_EQ(od.value(0x6060, 0, 1), 8U) << "010 is octal";
  EXPECT_EQ(od.value(0x6071, 0, 1), 0xFFFFU) << "-1 as an INTEGER16";
  EXPECT_EQ(od.value(0x6076, 0, 1), 2500U) << "a DCF's ParameterValue over the DefaultValue";
  EXPECT_EQ(od.value(0x2000, 0, 1), 0x3FC00000U) << "REAL32 1.5";
  EXPECT_EQ(od.find(0x6077), nullptr);
  try {
    (void)od.require(0x6077, 0, "torque actual value, for the cyclic reply");
    FAIL() << "no 0x6077";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "servo.eds: no object 0x6077:00 (torque actual value, for the cyclic reply)");
  }
}

TEST(Eds, NumbersInEveryNotationTheStandardAllows) {
  EXPECT_EQ(parse_eds_number("42", 0), 42);
  EXPECT_EQ(parse_eds_number("0x2A", 0), 42);
  EXPECT_EQ(parse_eds_number("0X2a", 0), 42);
  EXPECT_EQ(parse_eds_number("052", 0), 42);
  EXPECT_EQ(parse_eds_number("0", 0), 0);
  EXPECT_EQ(parse_eds_number("-7", 0), -7);
  EXPECT_EQ(parse_eds_number("$NODEID+0x180", 3), 0x183);
  EXPECT_EQ(parse_eds_number("0x180 + $NodeId", 3), 0x183);
  EXPECT_FALSE(parse_eds_number("", 0));
  EXPECT_FALSE(parse_eds_number("0x", 0));
  EXPECT_FALSE(parse_eds_number("12a", 0));
  EXPECT_FALSE(parse_eds_number("089", 0)) << "8 and 9 are no octal digits";
  EXPECT_FALSE(parse_eds_number("5+", 0));
}

/// The message of parsing `text` (which must fail).
std::string error_of(const std::string& text) {
  try {
    (void)ObjectDictionary::parse(text, "drive.eds");
  } catch (const ConfigError& e) {
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text;
  return "";
}

TEST(Eds, AMalformedFileIsRefusedWithItsFileLineSectionKeyAndValue) {
  const std::string head = "[6060]\nParameterName=Modes of operation\n";
  EXPECT_EQ(error_of(head + "DataType=0x0099\nAccessType=rw\n"),
            "drive.eds:3: [6060] DataType = 0x0099: expected a CiA 301 data type (0x0001 BOOLEAN ... 0x001B UNSIGNED64)");
  EXPECT_EQ(error_of(head + "DataType=0x0002\nAccessType=rx\n"), "drive.eds:4: [6060] AccessType = rx: expected ro, wo, rw, rwr, rww or const");
  EXPECT_EQ(error_of(head + "DataType=0x0002\nAccessType=rw\nPDOMapping=2\n"), "drive.eds:5: [6060] PDOMapping = 2: expected 0 or 1");
  EXPECT_EQ(error_of(head + "DataType=0x0006\nAccessType=rw\nDefaultValue=ten\n"),
            "drive.eds:5: [6060] DefaultValue = ten: expected a number (decimal, 0x hexadecimal, octal, or with $NODEID+)");
  EXPECT_EQ(error_of(head + "DataType=0x0002\nAccessType=rw\nObjectType=0x4\n"),
            "drive.eds:5: [6060] ObjectType = 0x4: expected 0x2 (DOMAIN), 0x5 (DEFTYPE), 0x6 (DEFSTRUCT), 0x7 (VAR), 0x8 (ARRAY) or 0x9 (RECORD)");
  EXPECT_EQ(error_of("\n[2000]\nDataType=0x0007\nAccessType=rw\n"), "drive.eds:2: [2000]: no ParameterName");
  EXPECT_EQ(error_of(head + "AccessType=rw\n"), "drive.eds:1: [6060] (Modes of operation): no DataType");
  EXPECT_EQ(error_of(head + "DataType=0x0002\n"), "drive.eds:1: [6060] (Modes of operation): no AccessType");
  EXPECT_EQ(error_of(head + "DataType=0x0002\nAccessType=rw\n[6060]\n"), "drive.eds:5: [6060] again (first at line 1)");
  EXPECT_EQ(error_of(head + "DataType=0x0002\nDataType=0x0003\n"), "drive.eds:4: [6060] DataType again (first at line 3)");
  EXPECT_EQ(error_of(head + "DataType 0x0002\n"), "drive.eds:3: 'DataType 0x0002': expected KEY=VALUE or [SECTION]");
  EXPECT_EQ(error_of("DataType=0x0002\n"), "drive.eds:1: 'DataType=0x0002' before any [SECTION]");
  EXPECT_EQ(error_of("[6060\n"), "drive.eds:1: '[6060': a section header is [NAME]");
  EXPECT_EQ(error_of("[1018]\nObjectType=0x9\nSubNumber=0\n"), "drive.eds:3: [1018] SubNumber = 0: expected the number of sub-objects, 1 to 255");
  // Windows line ends and comments are no error.
  EXPECT_EQ(ObjectDictionary::parse("; comment\r\n[6041]\r\nParameterName=Statusword\r\nDataType=0x0006\r\nAccessType=ro\r\n", "x.eds").size(), 1U);
  // A file that cannot be read names its path.
  try {
    (void)ObjectDictionary::load("/nonexistent/drive.eds");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/drive.eds: cannot read the EDS/DCF file"), std::string::npos) << e.what();
  }
}

}  // namespace
