// Phantom CINE (Vision Research): little-endian CINEFILEHEADER (44 bytes),
// BITMAPINFOHEADER, SETUP, tagged blocks, a table of int64 image offsets, and
// per image an annotation block (its size first, the image size last) before
// the pixels. Monochrome only: 8- or 16-bit words, or 10-bit packed four in
// five bytes (mapped to 12 bits through Phantom's linearisation table) or
// 12-bit packed two in three. Unpacked images are stored bottom-up (BMP
// style), packed ones top-down.
#include <cstring>
#include <vector>

#include "vision/footage_reader.hpp"

namespace collide::vision::detail {
namespace {

// CINEFILEHEADER field offsets.
constexpr std::uint64_t kHeaderSize = 44;
// SETUP field offsets (bytes from the start of SETUP), fixed since the
// 16-bit fields were superseded; files whose SETUP is shorter than kSetupNeed
// are older than this reader.
constexpr std::uint64_t kSetupMark = 140, kSetupLength = 142, kSetupSerial = 743, kSetupFlipV = 760,
                        kSetupFrameRate = 768, kSetupShutterUs = 772, kSetupCfa = 808,
                        kSetupRealBpp = 896, kSetupShutterNs = 1568;
constexpr std::uint64_t kSetupNeed = kSetupRealBpp + 4;
constexpr std::uint32_t kBiRgb = 0, kBiPacked = 256;

// Phantom's 10-bit to 12-bit linearisation table (the "LinLUT" of Vision
// Research's Cine file format documentation) for packed 10-bit images.
constexpr std::uint16_t kLinLut10[1024] = {
    2,    5,    6,    7,    8,    9,    10,   11,   12,   13,   14,   15,   16,   17,   17,   18,
    19,   20,   21,   22,   23,   24,   25,   26,   27,   28,   29,   30,   31,   32,   33,   33,
    34,   35,   36,   37,   38,   39,   40,   41,   42,   43,   44,   45,   46,   47,   48,   48,
    49,   50,   51,   52,   53,   54,   55,   56,   57,   58,   59,   60,   61,   62,   63,   63,
    64,   65,   66,   67,   68,   69,   70,   71,   72,   73,   74,   75,   76,   77,   78,   79,
    79,   80,   81,   82,   83,   84,   85,   86,   87,   88,   89,   90,   91,   92,   93,   94,
    94,   95,   96,   97,   98,   99,   100,  101,  102,  103,  104,  105,  106,  107,  108,  109,
    110,  110,  111,  112,  113,  114,  115,  116,  117,  118,  119,  120,  121,  122,  123,  124,
    125,  125,  126,  127,  128,  129,  130,  131,  132,  133,  134,  135,  136,  137,  137,  138,
    139,  140,  141,  142,  143,  144,  145,  146,  147,  148,  149,  150,  151,  152,  153,  154,
    156,  157,  158,  159,  160,  161,  162,  163,  164,  165,  167,  168,  169,  170,  171,  172,
    173,  175,  176,  177,  178,  179,  181,  182,  183,  184,  186,  187,  188,  189,  191,  192,
    193,  194,  196,  197,  198,  200,  201,  202,  204,  205,  206,  208,  209,  210,  212,  213,
    215,  216,  217,  219,  220,  222,  223,  225,  226,  227,  229,  230,  232,  233,  235,  236,
    238,  239,  241,  242,  244,  245,  247,  249,  250,  252,  253,  255,  257,  258,  260,  261,
    263,  265,  266,  268,  270,  271,  273,  275,  276,  278,  280,  281,  283,  285,  287,  288,
    290,  292,  294,  295,  297,  299,  301,  302,  304,  306,  308,  310,  312,  313,  315,  317,
    319,  321,  323,  325,  327,  328,  330,  332,  334,  336,  338,  340,  342,  344,  346,  348,
    350,  352,  354,  356,  358,  360,  362,  364,  366,  368,  370,  372,  374,  377,  379,  381,
    383,  385,  387,  389,  391,  394,  396,  398,  400,  402,  404,  407,  409,  411,  413,  416,
    418,  420,  422,  425,  427,  429,  431,  434,  436,  438,  441,  443,  445,  448,  450,  452,
    455,  457,  459,  462,  464,  467,  469,  472,  474,  476,  479,  481,  484,  486,  489,  491,
    494,  496,  499,  501,  504,  506,  509,  511,  514,  517,  519,  522,  524,  527,  529,  532,
    535,  537,  540,  543,  545,  548,  551,  553,  556,  559,  561,  564,  567,  570,  572,  575,
    578,  581,  583,  586,  589,  592,  594,  597,  600,  603,  606,  609,  611,  614,  617,  620,
    623,  626,  629,  632,  635,  637,  640,  643,  646,  649,  652,  655,  658,  661,  664,  667,
    670,  673,  676,  679,  682,  685,  688,  691,  694,  698,  701,  704,  707,  710,  713,  716,
    719,  722,  726,  729,  732,  735,  738,  742,  745,  748,  751,  754,  758,  761,  764,  767,
    771,  774,  777,  781,  784,  787,  790,  794,  797,  800,  804,  807,  811,  814,  817,  821,
    824,  828,  831,  834,  838,  841,  845,  848,  852,  855,  859,  862,  866,  869,  873,  876,
    880,  883,  887,  890,  894,  898,  901,  905,  908,  912,  916,  919,  923,  927,  930,  934,
    938,  941,  945,  949,  952,  956,  960,  964,  967,  971,  975,  979,  982,  986,  990,  994,
    998,  1001, 1005, 1009, 1013, 1017, 1021, 1025, 1028, 1032, 1036, 1040, 1044, 1048, 1052, 1056,
    1060, 1064, 1068, 1072, 1076, 1080, 1084, 1088, 1092, 1096, 1100, 1104, 1108, 1112, 1116, 1120,
    1124, 1128, 1132, 1137, 1141, 1145, 1149, 1153, 1157, 1162, 1166, 1170, 1174, 1178, 1183, 1187,
    1191, 1195, 1200, 1204, 1208, 1212, 1217, 1221, 1225, 1230, 1234, 1238, 1243, 1247, 1251, 1256,
    1260, 1264, 1269, 1273, 1278, 1282, 1287, 1291, 1295, 1300, 1304, 1309, 1313, 1318, 1322, 1327,
    1331, 1336, 1340, 1345, 1350, 1354, 1359, 1363, 1368, 1372, 1377, 1382, 1386, 1391, 1396, 1400,
    1405, 1410, 1414, 1419, 1424, 1428, 1433, 1438, 1443, 1447, 1452, 1457, 1462, 1466, 1471, 1476,
    1481, 1486, 1490, 1495, 1500, 1505, 1510, 1515, 1520, 1524, 1529, 1534, 1539, 1544, 1549, 1554,
    1559, 1564, 1569, 1574, 1579, 1584, 1589, 1594, 1599, 1604, 1609, 1614, 1619, 1624, 1629, 1634,
    1639, 1644, 1649, 1655, 1660, 1665, 1670, 1675, 1680, 1685, 1691, 1696, 1701, 1706, 1711, 1717,
    1722, 1727, 1732, 1738, 1743, 1748, 1753, 1759, 1764, 1769, 1775, 1780, 1785, 1791, 1796, 1801,
    1807, 1812, 1818, 1823, 1828, 1834, 1839, 1845, 1850, 1856, 1861, 1867, 1872, 1878, 1883, 1889,
    1894, 1900, 1905, 1911, 1916, 1922, 1927, 1933, 1939, 1944, 1950, 1956, 1961, 1967, 1972, 1978,
    1984, 1989, 1995, 2001, 2007, 2012, 2018, 2024, 2030, 2035, 2041, 2047, 2053, 2058, 2064, 2070,
    2076, 2082, 2087, 2093, 2099, 2105, 2111, 2117, 2123, 2129, 2135, 2140, 2146, 2152, 2158, 2164,
    2170, 2176, 2182, 2188, 2194, 2200, 2206, 2212, 2218, 2224, 2231, 2237, 2243, 2249, 2255, 2261,
    2267, 2273, 2279, 2286, 2292, 2298, 2304, 2310, 2317, 2323, 2329, 2335, 2341, 2348, 2354, 2360,
    2366, 2373, 2379, 2385, 2392, 2398, 2404, 2411, 2417, 2423, 2430, 2436, 2443, 2449, 2455, 2462,
    2468, 2475, 2481, 2488, 2494, 2501, 2507, 2514, 2520, 2527, 2533, 2540, 2546, 2553, 2559, 2566,
    2572, 2579, 2586, 2592, 2599, 2605, 2612, 2619, 2625, 2632, 2639, 2645, 2652, 2659, 2666, 2672,
    2679, 2686, 2693, 2699, 2706, 2713, 2720, 2726, 2733, 2740, 2747, 2754, 2761, 2767, 2774, 2781,
    2788, 2795, 2802, 2809, 2816, 2823, 2830, 2837, 2844, 2850, 2857, 2864, 2871, 2878, 2885, 2893,
    2900, 2907, 2914, 2921, 2928, 2935, 2942, 2949, 2956, 2963, 2970, 2978, 2985, 2992, 2999, 3006,
    3013, 3021, 3028, 3035, 3042, 3049, 3057, 3064, 3071, 3078, 3086, 3093, 3100, 3108, 3115, 3122,
    3130, 3137, 3144, 3152, 3159, 3166, 3174, 3181, 3189, 3196, 3204, 3211, 3218, 3226, 3233, 3241,
    3248, 3256, 3263, 3271, 3278, 3286, 3294, 3301, 3309, 3316, 3324, 3331, 3339, 3347, 3354, 3362,
    3370, 3377, 3385, 3393, 3400, 3408, 3416, 3423, 3431, 3439, 3447, 3454, 3462, 3470, 3478, 3486,
    3493, 3501, 3509, 3517, 3525, 3533, 3540, 3548, 3556, 3564, 3572, 3580, 3588, 3596, 3604, 3612,
    3620, 3628, 3636, 3644, 3652, 3660, 3668, 3676, 3684, 3692, 3700, 3708, 3716, 3724, 3732, 3740,
    3749, 3757, 3765, 3773, 3781, 3789, 3798, 3806, 3814, 3822, 3830, 3839, 3847, 3855, 3863, 3872,
    3880, 3888, 3897, 3905, 3913, 3922, 3930, 3938, 3947, 3955, 3963, 3972, 3980, 3989, 3997, 4006,
    4014, 4022, 4031, 4039, 4048, 4056, 4064, 4095, 4095, 4095, 4095, 4095, 4095, 4095, 4095, 4095,
};

class CineReader final : public FootageReader {
 public:
  std::shared_ptr<const MappedFile> file;
  std::vector<std::uint64_t> pixels_at;  // file offset of each image's pixels
  std::uint64_t stride = 0;              // bytes per stored row (unpacked)
  bool bottom_up = true;

  Status decode(std::int64_t index, cv::Mat& out) const override {
    const std::uint8_t* src = file->data() + pixels_at[static_cast<std::size_t>(index)];
    const int h = info.height;
    const std::size_t w = static_cast<std::size_t>(info.width);
    auto stored_row = [&](int r) { return bottom_up ? h - 1 - r : r; };
    if (!info.packed) {
      for (int r = 0; r < h; ++r) {
        const std::uint8_t* in = src + stride * static_cast<std::uint64_t>(stored_row(r));
        if (info.stored_bits == 8) {
          std::memcpy(out.ptr(r), in, w);
        } else {
          std::uint16_t* row = out.ptr<std::uint16_t>(r);
          for (std::size_t c = 0; c < w; ++c) row[c] = le16(in + 2 * c);
        }
      }
      return Ok{};
    }
    const std::size_t pixels = w * static_cast<std::size_t>(h);
    thread_local std::vector<std::uint16_t> tmp;
    tmp.resize(pixels);
    if (info.stored_bits == 10)
      unpack10(src, tmp.data(), pixels, kLinLut10);
    else
      unpack12(src, tmp.data(), pixels);
    for (int r = 0; r < h; ++r)
      std::memcpy(out.ptr(r), tmp.data() + w * static_cast<std::size_t>(stored_row(r)), 2 * w);
    return Ok{};
  }
};

}  // namespace

const std::uint16_t* phantomLinLut10() {
  return kLinLut10;
}

namespace {

// The file's fields this reader uses, as read and checked stage by stage.
struct CineLayout {
  const MappedFile& f;
  const std::string& path;
  const std::uint8_t* d;
  // CINEFILEHEADER
  std::int32_t first_image_no = 0;
  std::uint32_t image_count = 0;
  std::uint32_t off_bmi = 0, off_setup = 0, off_offsets = 0;
  // BITMAPINFOHEADER
  std::int32_t bi_width = 0, bi_height = 0;
  std::uint16_t bit_count = 0;
  std::uint32_t bi_compression = 0;
  std::int32_t pels_per_m = 0;
  std::int64_t width = 0, height = 0;
  // SETUP
  const std::uint8_t* setup = nullptr;
  std::uint16_t setup_length = 0;

  Error bad(const std::string& what) const {
    return fail(path + ": " + what + ": the file is damaged, truncated or not a Phantom CINE");
  }

  // CINEFILEHEADER: the mark, version 1, uncompressed, at least one image.
  Status readHeader() {
    if (!f.holds(0, kHeaderSize) || d[0] != 'C' || d[1] != 'I')
      return fail(path +
                  " is not a Phantom CINE file (it does not start with 'CI'): check the "
                  "file, or convert it to PNG frames");
    const std::uint16_t header_size = le16(d + 2), compression = le16(d + 4), version = le16(d + 6);
    first_image_no = static_cast<std::int32_t>(le32(d + 16));
    image_count = le32(d + 20);
    off_bmi = le32(d + 24), off_setup = le32(d + 28), off_offsets = le32(d + 32);
    if (header_size < kHeaderSize)
      return bad("header size " + std::to_string(header_size) + " < 44");
    if (version != 1)
      return fail(path + ": CINE version " + std::to_string(version) +
                  " (this reader knows version 1): convert it with Phantom PCC or to PNG frames");
    if (compression != 0)
      return fail(path + ": CINE compression " + std::to_string(compression) +
                  (compression == 2 ? " (raw colour sensor data)" : " (JPEG)") +
                  "; only uncompressed monochrome CINE is read: save it from PCC as "
                  "uncompressed grey, or convert it to PNG frames");
    if (image_count < 1) return bad("the header says it holds no images");
    return Ok{};
  }

  // BITMAPINFOHEADER: a possible size, 8- or 16-bit grey or packed 10/12-bit.
  Status readBitmapInfo() {
    if (!f.holds(off_bmi, 40)) return bad("the image header lies beyond the end of the file");
    const std::uint8_t* bmi = d + off_bmi;
    bi_width = static_cast<std::int32_t>(le32(bmi + 4));
    bi_height = static_cast<std::int32_t>(le32(bmi + 8));
    bit_count = le16(bmi + 14);
    bi_compression = le32(bmi + 16);
    pels_per_m = static_cast<std::int32_t>(le32(bmi + 24));
    width = bi_width;
    height = bi_height < 0 ? -std::int64_t{bi_height} : bi_height;
    if (width < 1 || height < 1 || width > kMaxSide || height > kMaxSide ||
        width * height > kMaxPixels)
      return bad("image size " + std::to_string(bi_width) + " x " + std::to_string(bi_height) +
                 " is impossible");
    if (bi_compression != kBiRgb && bi_compression != kBiPacked)
      return fail(path + ": bitmap compression " + std::to_string(bi_compression) +
                  " is not one this reader decodes (uncompressed or packed 10/12-bit)");
    if (bi_compression == kBiRgb && bit_count != 8 && bit_count != 16)
      return fail(path + ": " + std::to_string(bit_count) + "-bit pixels" +
                  (bit_count == 24 || bit_count == 48 ? " (colour)" : "") +
                  "; only 8- or 16-bit monochrome CINE is read: convert it to grey PNG frames");
    return Ok{};
  }

  // SETUP: marked, recent enough to hold what is read, monochrome.
  Status readSetup() {
    if (!f.holds(off_setup, kSetupLength + 2)) return bad("the setup block lies beyond the end");
    setup = d + off_setup;
    setup_length = le16(setup + kSetupLength);
    if (setup[kSetupMark] != 'S' || setup[kSetupMark + 1] != 'T')
      return bad("the setup block has no 'ST' mark");
    if (setup_length < kSetupNeed)
      return fail(path + ": setup block of " + std::to_string(setup_length) +
                  " bytes, from a Phantom software older than this reader knows: re-save it "
                  "with a current PCC");
    if (!f.holds(off_setup, setup_length)) return bad("the setup block runs past the end");
    if ((le32(setup + kSetupCfa) & 0xFFFFFF) != 0)
      return fail(path +
                  " holds colour (Bayer) sensor data; only monochrome CINE is read: "
                  "convert it to grey PNG frames");
    return Ok{};
  }

  // What the header, bitmap and setup say about the footage, and how rows
  // are stored.
  void describe(CineReader& r) const {
    FootageInfo& in = r.info;
    in.format = "Phantom CINE";
    in.data_path = path;
    in.width = static_cast<int>(width);
    in.height = static_cast<int>(height);
    in.fps = le32(setup + kSetupFrameRate);
    const std::uint32_t shutter_ns =
        setup_length >= kSetupShutterNs + 4 ? le32(setup + kSetupShutterNs) : 0;
    in.exposure_s = shutter_ns > 0 ? shutter_ns * 1e-9 : le32(setup + kSetupShutterUs) * 1e-6;
    if (const std::uint32_t serial = le32(setup + kSetupSerial); serial != 0)
      in.camera = "Phantom, serial " + std::to_string(serial);
    in.first_frame = first_image_no;
    in.trigger_known = true;
    if (pels_per_m > 0) in.sensor_pixel_m = 1.0 / pels_per_m;
    // Unpacked images are bottom-up, packed ones top-down (as PIMS and pycine
    // read them). bFlipV is a display preference and is not applied: on the
    // test vector (bubbles rising from a needle) applying it, as FFmpeg does,
    // turns the scene upside down.
    r.bottom_up = bi_compression == kBiRgb;
    if (bi_height < 0) r.bottom_up = !r.bottom_up;
    if (le32(setup + kSetupFlipV) != 0)
      in.note =
          "the file asks viewers to flip it vertically (bFlipV); frames are given as "
          "recorded: if gravity points up in them, use --gravity-dir up";
  }

  // The first image's size sets the pixels' packing: 10- or 12-bit packed,
  // or 8/16-bit rows (padded to 4 bytes or not).
  Status pixelLayout(std::uint64_t image_size, CineReader& r) const {
    FootageInfo& in = r.info;
    const std::uint64_t pixels = static_cast<std::uint64_t>(width * height);
    if (bi_compression == kBiPacked) {
      if (image_size * 8 == pixels * 10 && pixels % 4 == 0) {
        in.stored_bits = 10;
      } else if (image_size * 8 == pixels * 12 && pixels % 2 == 0) {
        in.stored_bits = 12;
      } else {
        return bad("packed images of " + std::to_string(image_size) + " bytes for " +
                   std::to_string(pixels) + " pixels are neither 10- nor 12-bit");
      }
      in.packed = true;
      in.frame_bytes = image_size;
      in.effective_bits = 12;
      return Ok{};
    }
    in.stored_bits = bit_count;
    r.stride = static_cast<std::uint64_t>(width) * (bit_count / 8);
    const std::uint64_t padded = (r.stride + 3) & ~std::uint64_t{3};
    if (image_size == padded * static_cast<std::uint64_t>(height)) r.stride = padded;
    in.frame_bytes = r.stride * static_cast<std::uint64_t>(height);
    const std::uint32_t real_bpp = le32(setup + kSetupRealBpp);
    in.effective_bits = real_bpp >= 1 && static_cast<int>(real_bpp) <= in.stored_bits
                            ? static_cast<int>(real_bpp)
                            : in.stored_bits;
    return Ok{};
  }

  // Each image's pixels, from the table of offsets past its annotation:
  // bounded by the file before anything is allocated, each image checked to
  // lie within it.
  Status imageOffsets(CineReader& r) const {
    if (!f.holds(off_offsets, std::uint64_t{8} * image_count))
      return fail(path + " says it holds " + std::to_string(image_count) +
                  " images but its table of image offsets runs past the end of the file: the "
                  "file is truncated (an interrupted copy?); copy it again");
    r.pixels_at.resize(image_count);
    for (std::uint32_t i = 0; i < image_count; ++i) {
      const std::uint64_t at = le64(d + off_offsets + 8 * std::uint64_t{i});
      const std::string which = "image " + std::to_string(i) + " of " + std::to_string(image_count);
      auto truncated = [&] {
        return fail(path + ": " + which +
                    " lies beyond the end of the file: the file is truncated (an interrupted "
                    "copy?); copy it again");
      };
      if (!f.holds(at, 8)) return truncated();
      const std::uint32_t annotation = le32(d + at);
      if (annotation < 8)
        return bad(which + " has an annotation of " + std::to_string(annotation) + " bytes");
      if (!f.holds(at, annotation)) return truncated();
      if (i == 0)
        if (Status ok = pixelLayout(le32(d + at + annotation - 4), r); !ok) return ok;
      if (!f.holds(at + annotation, r.info.frame_bytes)) return truncated();
      r.pixels_at[i] = at + annotation;
    }
    return Ok{};
  }
};

}  // namespace

Result<std::unique_ptr<FootageReader>> openCine(const std::string& path) {
  auto mapped = MappedFile::open(path);
  if (!mapped) return mapped.error();
  CineLayout c{**mapped, path, (*mapped)->data()};
  if (Status ok = c.readHeader(); !ok) return ok.error();
  if (Status ok = c.readBitmapInfo(); !ok) return ok.error();
  if (Status ok = c.readSetup(); !ok) return ok.error();
  auto r = std::make_unique<CineReader>();
  c.describe(*r);
  if (Status ok = c.imageOffsets(*r); !ok) return ok.error();
  r->info.frame_count = c.image_count;
  r->info.pixel_format = pixelFormatFor(r->info.stored_bits, r->info.effective_bits);
  r->file = std::move(*mapped);
  return std::unique_ptr<FootageReader>(std::move(r));
}

}  // namespace collide::vision::detail
