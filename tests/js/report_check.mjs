// report.html opened by a real browser (Debian's headless Chromium) with every
// host name unresolvable, so nothing can be fetched: no script errors, the 3-D
// view and the tables ready, as many boxes drawn as boxes.csv has rows, and a
// screenshot (written beside the report) that is not blank.
//   node report_check.mjs CHROMIUM OUT_DIR
// Exit 0: passed; 1: a check failed; 77: pngjs missing.
import { execFileSync } from "node:child_process";
import { readFileSync } from "node:fs";

let PNG;
try {
  ({ PNG } = await import("pngjs"));
} catch (e) {
  console.log(`SKIP: npm module pngjs missing (tools/test installs it into tests/js): ${e.message}`);
  process.exit(77);
}
const [chromium, out] = process.argv.slice(2);
const page = `file://${out}/report.html`;
const flags = [
  "--headless",
  "--no-sandbox",
  "--disable-gpu",
  "--use-angle=swiftshader",
  "--enable-unsafe-swiftshader",
  "--host-resolver-rules=MAP * ~NOTFOUND",
  "--window-size=1280,1400",
  "--virtual-time-budget=10000",
];
const run = (extra) =>
  execFileSync(chromium, [...flags, ...extra, page], {
    encoding: "utf8",
    stdio: ["ignore", "pipe", "ignore"],
    timeout: 120000,
    maxBuffer: 1 << 28, // the page holds every box and cell: --dump-dom is big
  });

const failures = [];
const check = (ok, what) => {
  if (!ok) failures.push(what);
};
const html = readFileSync(`${out}/report.html`, "utf8");
check(!/<(script|link|img)[^>]+(src|href)="(https?:)?\/\//i.test(html), "the page refers to a remote resource");

const dom = run(["--dump-dom"]);
const attribute = (tag, name) => {
  const m = dom.match(new RegExp(`<${tag}[^>]*\\s${name}="([^"]*)"`));
  return m ? m[1] : undefined;
};
const errors = attribute("html", "data-errors");
check(errors === undefined, `script errors: ${errors}`);
check(attribute("body", "data-view-ready") === "1", "the 3-D view did not finish");
check(attribute("body", "data-tables-ready") === "1", "the tables did not finish");
const rows = readFileSync(`${out}/boxes.csv`, "utf8").trim().split("\n").length - 1;
const shown = Number(attribute("body", "data-boxes-shown"));
check(shown === rows, `${shown} boxes drawn, boxes.csv has ${rows}`);
const statsRows = (dom.match(/<tr>/g) ?? []).length;
check(statsRows > 40, `only ${statsRows} table rows (every stats.json counter should be there)`);

const shot = `${out}/report-screenshot.png`;
run([`--screenshot=${shot}`]);
const png = PNG.sync.read(readFileSync(shot));
const colours = new Set();
let dark = 0; // the 3-D view's background and what is drawn on it
for (let i = 0; i < png.data.length; i += 4) {
  colours.add((png.data[i] << 16) | (png.data[i + 1] << 8) | png.data[i + 2]);
  if (png.data[i] < 40 && png.data[i + 1] < 40 && png.data[i + 2] < 40) ++dark;
}
check(colours.size > 200, `screenshot has ${colours.size} colours: blank?`);
check(dark > png.width * png.height * 0.1, "no 3-D view on the screenshot");

console.log(
  `report.html: ${html.length} bytes; ${shown} boxes drawn (boxes.csv ${rows}); ${statsRows} table rows; ` +
    `screenshot ${png.width}x${png.height}, ${colours.size} colours -> ${shot}`,
);
if (failures.length) {
  for (const f of failures) console.log(`FAIL: ${f}`);
  process.exit(1);
}
console.log("PASS: rendered by headless Chromium without errors, nothing fetched");
