#include "app/store/catalog.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>

#include "app/store/save.hpp"
#include "tests/app/shot_fixtures.hpp"

namespace {

using collide::app::Catalog;
using collide::app::CatalogRow;
using collide::app::catalogRow;
using collide::app::rebuildCatalog;
using collide::app::ShotFilter;
using collide::hw::ShotStatus;
using namespace collide::testing;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr std::int64_t kDay_ns = 86400LL * 1000000000LL;

void expectSameRow(const CatalogRow& e, const CatalogRow& a) {
  SCOPED_TRACE("shot " + e.id);
  EXPECT_EQ(a.id, e.id);
  EXPECT_EQ(a.file, e.file);
  EXPECT_EQ(a.wall_time_unix_ns, e.wall_time_unix_ns);
  EXPECT_EQ(a.rig_name, e.rig_name);
  EXPECT_EQ(a.material, e.material);
  for (int k = 0; k < 2; ++k) {
    EXPECT_TRUE(sameDouble(a.wanted_speed_m_s[k], e.wanted_speed_m_s[k])) << k;
    EXPECT_EQ(a.commanded_kPa[k], e.commanded_kPa[k]) << k;
    EXPECT_EQ(a.readback_kPa[k], e.readback_kPa[k]) << k;
  }
  EXPECT_EQ(a.status, e.status);
  EXPECT_EQ(a.failure_reason, e.failure_reason);
  EXPECT_EQ(a.frames, e.frames);
  EXPECT_EQ(a.analysed, e.analysed);
  EXPECT_EQ(a.results.e, e.results.e);
  EXPECT_EQ(a.results.beta, e.results.beta);
  EXPECT_EQ(a.results.f, e.results.f);
  EXPECT_EQ(a.results.gamma_deg, e.results.gamma_deg);
  EXPECT_EQ(a.results.vn_m_s, e.results.vn_m_s);
  EXPECT_EQ(a.results.vs_m_s, e.results.vs_m_s);
  EXPECT_EQ(a.results.quality_flags, e.results.quality_flags);
}

/// Four shots over three days: two nylon, one teflon, one failed nylon.
std::vector<collide::hw::Shot> campaign() {
  std::vector<collide::hw::Shot> shots;
  const std::int64_t t0 = ShotSpec{}.wall_time_unix_ns;
  const struct {
    const char* id;
    int day;
    const char* material;
    ShotStatus status;
    bool results;
  } plan[] = {
      {"20260314-101500-0001", 0, "nylon-6/6", ShotStatus::Ok, true},
      {"20260315-101500-0002", 1, "teflon", ShotStatus::Ok, false},
      {"20260315-101500-0003", 1, "nylon-6/6", ShotStatus::Failed, false},
      {"20260316-101500-0004", 2, "nylon-6/6", ShotStatus::Ok, false},
  };
  for (const auto& p : plan) {
    ShotSpec spec;
    spec.id = p.id;
    spec.wall_time_unix_ns = t0 + p.day * kDay_ns + (p.id[19] - '0');
    spec.material = p.material;
    spec.status = p.status;
    spec.results = p.results;
    spec.truth = false;
    spec.frames = 4;
    spec.width = 8;
    spec.height = 6;
    spec.commanded_kPa = 100.0 + 10.0 * shots.size();
    shots.push_back(makeShot(spec));
  }
  return shots;
}

std::vector<std::string> ids(const std::vector<CatalogRow>& rows) {
  std::vector<std::string> out;
  for (const auto& r : rows) out.push_back(r.id);
  return out;
}

class CatalogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    auto opened = Catalog::open(dir.path());
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    catalog.emplace(std::move(*opened));
    for (const auto& shot : shots) {
      rows.push_back(catalogRow(shot, shot.id + ".h5"));
      // Inserted newest first: the catalog must sort them.
    }
    for (auto it = rows.rbegin(); it != rows.rend(); ++it) {
      const auto s = catalog->upsert(*it);
      ASSERT_TRUE(s.ok()) << s.error().message;
    }
  }
  std::vector<CatalogRow> query(const ShotFilter& f = {}) {
    auto r = catalog->query(f);
    EXPECT_TRUE(r.ok()) << r.error().message;
    return r.ok() ? *r : std::vector<CatalogRow>{};
  }

  ScratchDir dir;
  std::vector<collide::hw::Shot> shots = campaign();
  std::vector<CatalogRow> rows;
  std::optional<Catalog> catalog;
};

TEST_F(CatalogTest, ListsEveryShotOldestFirstWithEveryColumn) {
  const auto listed = query();
  ASSERT_EQ(listed.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) expectSameRow(rows[i], listed[i]);
  // The fixture's second launcher had no wanted speed: NULL comes back as NaN.
  EXPECT_TRUE(std::isnan(listed[0].wanted_speed_m_s[1]));
  EXPECT_EQ(listed[0].wanted_speed_m_s[0], 2.5);
  EXPECT_EQ(listed[2].failure_reason, shots[2].failure_reason);
  EXPECT_EQ(listed[0].frames, 4);
}

TEST_F(CatalogTest, ResultsColumnsAreNullUntilAnalysed) {
  const auto listed = query();
  EXPECT_TRUE(listed[0].analysed);
  EXPECT_EQ(listed[0].results.e, 0.93);
  EXPECT_EQ(listed[0].results.gamma_deg, 135.5);
  EXPECT_THAT(listed[0].results.quality_flags, ElementsAre("grazing", "few_frames"));
  EXPECT_FALSE(listed[1].analysed);
  EXPECT_FALSE(listed[1].results.e.has_value());
  EXPECT_FALSE(listed[1].results.vn_m_s.has_value());
  EXPECT_TRUE(listed[1].results.quality_flags.empty());
}

TEST_F(CatalogTest, FiltersByMaterialStatusAndDate) {
  ShotFilter nylon;
  nylon.material = "nylon-6/6";
  EXPECT_THAT(ids(query(nylon)), ElementsAre(rows[0].id, rows[2].id, rows[3].id));
  ShotFilter failed;
  failed.status = ShotStatus::Failed;
  EXPECT_THAT(ids(query(failed)), ElementsAre(rows[2].id));
  ShotFilter ok_nylon = nylon;
  ok_nylon.status = ShotStatus::Ok;
  EXPECT_THAT(ids(query(ok_nylon)), ElementsAre(rows[0].id, rows[3].id));
  // Day 1 only: since is inclusive, until exclusive.
  ShotFilter day1;
  day1.since_unix_ns = rows[1].wall_time_unix_ns;
  day1.until_unix_ns = rows[3].wall_time_unix_ns;
  EXPECT_THAT(ids(query(day1)), ElementsAre(rows[1].id, rows[2].id));
  ShotFilter none;
  none.material = "glass";
  EXPECT_TRUE(query(none).empty());
}

TEST_F(CatalogTest, UpsertReplacesTheRowWithTheSameId) {
  CatalogRow changed = rows[1];
  changed.readback_kPa = {55.5, 66.5};
  changed.status = ShotStatus::Failed;
  changed.failure_reason = "valve 1 did not open";
  ASSERT_TRUE(catalog->upsert(changed).ok());
  const auto listed = query();
  ASSERT_EQ(listed.size(), rows.size());
  expectSameRow(changed, listed[1]);
}

TEST_F(CatalogTest, UpdateResultsSetsAndClearsTheResultColumns) {
  const auto s = catalog->updateResults(
      rows[1].id, R"({"e": 0.88, "beta": -0.2, "vs_m_s": 0.5, "quality_flags": ["low_spin"]})");
  ASSERT_TRUE(s.ok()) << s.error().message;
  auto listed = query();
  EXPECT_TRUE(listed[1].analysed);
  EXPECT_EQ(listed[1].results.e, 0.88);
  EXPECT_EQ(listed[1].results.beta, -0.2);
  EXPECT_EQ(listed[1].results.vs_m_s, 0.5);
  EXPECT_FALSE(listed[1].results.f.has_value());  // absent from the JSON: NULL
  EXPECT_THAT(listed[1].results.quality_flags, ElementsAre("low_spin"));
  expectSameRow(rows[0], listed[0]);  // others untouched

  ASSERT_TRUE(catalog->updateResults(rows[0].id, "").ok());
  listed = query();
  EXPECT_FALSE(listed[0].analysed);
  EXPECT_FALSE(listed[0].results.e.has_value());
  EXPECT_TRUE(listed[0].results.quality_flags.empty());
}

TEST_F(CatalogTest, UpdateResultsOfAnUnknownShotSaysSo) {
  const auto s = catalog->updateResults("20990101-000000-0000", R"({"e": 1})");
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message,
              AllOf(HasSubstr("no shot 20990101-000000-0000"), HasSubstr("catalog rebuild")));
}

TEST_F(CatalogTest, SurvivesReopeningInWalModeWithItsSchemaVersion) {
  catalog.reset();
  auto reopened = Catalog::open(dir.path(), Catalog::Mode::OpenExisting);
  ASSERT_TRUE(reopened.ok()) << reopened.error().message;
  auto listed = reopened->query();
  ASSERT_TRUE(listed.ok());
  EXPECT_EQ(listed->size(), rows.size());

  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(dir.file("catalog.sqlite").c_str(), &db), SQLITE_OK);
  auto pragma = [&](const char* sql) {
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db, sql, -1, &s, nullptr);
    std::string v = sqlite3_step(s) == SQLITE_ROW
                        ? reinterpret_cast<const char*>(sqlite3_column_text(s, 0))
                        : "";
    sqlite3_finalize(s);
    return v;
  };
  EXPECT_EQ(pragma("PRAGMA journal_mode"), "wal");
  EXPECT_EQ(pragma("PRAGMA user_version"), std::to_string(collide::app::kCatalogSchemaVersion));
  sqlite3_close(db);
}

TEST(CatalogOpen, ListingDoesNotCreateACatalog) {
  ScratchDir dir;
  auto opened = Catalog::open(dir.path(), Catalog::Mode::OpenExisting);
  ASSERT_FALSE(opened.ok());
  EXPECT_THAT(opened.error().message,
              AllOf(HasSubstr(dir.path()), HasSubstr("collide catalog rebuild")));
  EXPECT_TRUE(dir.entries().empty());
}

TEST(CatalogOpen, MissingFolderIsNamed) {
  ScratchDir dir;
  auto opened = Catalog::open(dir.file("nowhere"));
  ASSERT_FALSE(opened.ok());
  EXPECT_THAT(opened.error().message, HasSubstr("no such shot folder: " + dir.file("nowhere")));
}

TEST(CatalogOpen, CorruptCatalogPointsToRebuild) {
  ScratchDir dir;
  writeAll(dir.file("catalog.sqlite"), std::string(8192, 'x'));
  auto opened = Catalog::open(dir.path());
  ASSERT_FALSE(opened.ok());
  EXPECT_THAT(opened.error().message,
              AllOf(HasSubstr("corrupt"), HasSubstr("collide catalog rebuild " + dir.path())));
}

// A catalog written before notes existed (schema 1) opens, keeps its rows,
// gains the note column and takes notes.
TEST(CatalogOpen, SchemaOneIsBroughtUpToDate) {
  ScratchDir dir;
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(dir.file("catalog.sqlite").c_str(), &db), SQLITE_OK);
  const char* v1 = R"sql(
CREATE TABLE shots (
  id TEXT PRIMARY KEY NOT NULL, file TEXT NOT NULL, wall_time_unix_ns INTEGER NOT NULL,
  rig_name TEXT NOT NULL, material TEXT NOT NULL, wanted_speed_0_m_s REAL,
  wanted_speed_1_m_s REAL, commanded_0_kpa REAL, commanded_1_kpa REAL, readback_0_kpa REAL,
  readback_1_kpa REAL, status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
  failure_reason TEXT NOT NULL, frames INTEGER NOT NULL,
  analysed INTEGER NOT NULL CHECK (analysed IN (0, 1)), e REAL, beta REAL, f REAL,
  gamma_deg REAL, vn_m_s REAL, vs_m_s REAL, quality_flags TEXT);
INSERT INTO shots VALUES ('20260101-000000-0001', '20260101-000000-0001.h5', 5, 'rig', 'nylon',
  1.0, 2.0, 30.0, 31.0, 30.1, 31.1, 'ok', '', 70, 1, 0.9, 0.3, 0.1, 40.0, -1.0, 0.5, '');
PRAGMA user_version = 1;)sql";
  ASSERT_EQ(sqlite3_exec(db, v1, nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  auto opened = Catalog::open(dir.path(), Catalog::Mode::OpenExisting);
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  auto rows = opened->query();
  ASSERT_TRUE(rows.ok()) << rows.error().message;
  ASSERT_EQ(rows->size(), 1u);
  EXPECT_EQ((*rows)[0].material, "nylon");
  EXPECT_EQ((*rows)[0].results.e, 0.9);
  EXPECT_EQ((*rows)[0].note, "");
  ASSERT_TRUE(opened->updateNote("20260101-000000-0001", "first of the day").ok());
  EXPECT_EQ((*opened->query())[0].note, "first of the day");
  EXPECT_FALSE(opened->updateNote("20260101-000000-0002", "x").ok());
}

TEST(CatalogOpen, NewerSchemaIsRefused) {
  ScratchDir dir;
  { ASSERT_TRUE(Catalog::open(dir.path()).ok()); }
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(dir.file("catalog.sqlite").c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db, "PRAGMA user_version = 99", nullptr, nullptr, nullptr), SQLITE_OK);
  sqlite3_close(db);
  auto opened = Catalog::open(dir.path());
  ASSERT_FALSE(opened.ok());
  EXPECT_THAT(opened.error().message, AllOf(HasSubstr("newer collide"), HasSubstr("schema 99")));
}

// ------------------------------------------------------------ rebuild

class RebuildTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const auto& shot : shots) {
      const auto s = collide::app::saveShot(dir.path(), shot);
      ASSERT_TRUE(s.ok()) << s.error().message;
    }
    // Results added after the recording reach both the file and the row.
    const auto s =
        collide::app::saveResults(dir.path(), shots[3].id, R"({"e": 0.7, "quality_flags": []})");
    ASSERT_TRUE(s.ok()) << s.error().message;
    auto listed = Catalog::open(dir.path())->query();
    ASSERT_TRUE(listed.ok());
    original = *listed;
    ASSERT_EQ(original.size(), shots.size());
    ASSERT_TRUE(original[3].analysed);
  }

  std::vector<CatalogRow> rebuiltRows() {
    auto listed = Catalog::open(dir.path(), Catalog::Mode::OpenExisting);
    EXPECT_TRUE(listed.ok()) << listed.error().message;
    auto rows = listed->query();
    EXPECT_TRUE(rows.ok());
    return *rows;
  }

  ScratchDir dir;
  std::vector<collide::hw::Shot> shots = campaign();
  std::vector<CatalogRow> original;
};

TEST_F(RebuildTest, FromTheFilesAloneGivesTheSameRows) {
  for (const char* suffix : {"", "-wal", "-shm"})
    std::filesystem::remove(dir.file(std::string("catalog.sqlite") + suffix));
  const auto report = rebuildCatalog(dir.path());
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->shots, shots.size());
  EXPECT_TRUE(report->unreadable.empty());
  const auto rebuilt = rebuiltRows();
  ASSERT_EQ(rebuilt.size(), original.size());
  for (std::size_t i = 0; i < original.size(); ++i) expectSameRow(original[i], rebuilt[i]);
}

TEST_F(RebuildTest, ReportsUnreadableFilesAndCarriesOn) {
  writeAll(dir.file("aaa-notes.h5"), "not a shot");
  const std::string bytes = readAll(dir.file(shots[1].id + ".h5"));
  writeAll(dir.file("cut.h5"), bytes.substr(0, bytes.size() / 3));
  // A write in progress (hidden temporary name) is not a shot yet.
  writeAll(dir.file(".x.h5.tmp-abcdef"), "partial");
  const auto report = rebuildCatalog(dir.path());
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->shots, shots.size());
  ASSERT_EQ(report->unreadable.size(), 2u);
  EXPECT_EQ(report->unreadable[0].file, "aaa-notes.h5");
  EXPECT_THAT(report->unreadable[0].message, HasSubstr("not an HDF5 file"));
  EXPECT_EQ(report->unreadable[1].file, "cut.h5");
  EXPECT_THAT(report->unreadable[1].message, HasSubstr("truncated or corrupt"));
  const auto rebuilt = rebuiltRows();
  ASSERT_EQ(rebuilt.size(), original.size());
  for (std::size_t i = 0; i < original.size(); ++i) expectSameRow(original[i], rebuilt[i]);
}

TEST_F(RebuildTest, ReportsACopiedShotInsteadOfListingItTwice) {
  std::filesystem::copy_file(dir.file(shots[0].id + ".h5"), dir.file("zz-copy.h5"));
  const auto report = rebuildCatalog(dir.path());
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_EQ(report->unreadable.size(), 1u);
  EXPECT_EQ(report->unreadable[0].file, "zz-copy.h5");
  EXPECT_THAT(report->unreadable[0].message, HasSubstr(shots[0].id + ".h5"));
  EXPECT_EQ(rebuiltRows().size(), shots.size());
}

TEST_F(RebuildTest, ReplacesACorruptCatalog) {
  for (const char* suffix : {"", "-wal", "-shm"})
    std::filesystem::remove(dir.file(std::string("catalog.sqlite") + suffix));
  writeAll(dir.file("catalog.sqlite"), std::string(8192, 'x'));
  const auto report = rebuildCatalog(dir.path());
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(rebuiltRows().size(), shots.size());
}

TEST(Rebuild, MissingFolderIsAnError) {
  ScratchDir dir;
  const auto report = rebuildCatalog(dir.file("gone"));
  ASSERT_FALSE(report.ok());
  EXPECT_THAT(report.error().message, HasSubstr(dir.file("gone")));
}

}  // namespace
