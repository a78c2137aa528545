//! The page's style sheet, inline: light backgrounds only, system fonts (nothing
//! fetched), and print rules (A4, figures and tables kept whole, no navigation).

/// The CSS of every page.
pub const CSS: &str = r#"
:root { --ink: #1d1d1f; --muted: #5b5b66; --rule: #d0d0d8; --soft: #f4f5f8; --accent: #1f5fa8; }
* { box-sizing: border-box; }
body { margin: 0; background: #ffffff; color: var(--ink);
  font: 15px/1.5 system-ui, -apple-system, "Segoe UI", Roboto, "Helvetica Neue", Arial, sans-serif; }
main { max-width: 980px; margin: 0 auto; padding: 28px 28px 60px; }
h1 { font-size: 1.75rem; margin: 0 0 4px; line-height: 1.25; }
h2 { font-size: 1.3rem; margin: 2.2em 0 0.5em; padding-bottom: 4px; border-bottom: 2px solid var(--accent); }
h3 { font-size: 1.05rem; margin: 1.6em 0 0.4em; }
p { margin: 0.5em 0; }
.subtitle { color: var(--muted); margin: 0 0 14px; }
.facts { display: grid; grid-template-columns: repeat(auto-fill, minmax(210px, 1fr)); gap: 6px 18px;
  margin: 12px 0 18px; padding: 12px 16px; background: var(--soft); border: 1px solid var(--rule); border-radius: 6px; }
.facts div { min-width: 0; }
.facts dt { font-size: 0.78rem; color: var(--muted); text-transform: uppercase; letter-spacing: 0.03em; }
.facts dd { margin: 0; font-weight: 600; overflow-wrap: anywhere; }
nav h2 { font-size: 1rem; border: none; margin: 0.6em 0 0.2em; }
nav ol { columns: 2; margin: 0; padding-left: 1.4em; }
nav a { color: var(--accent); text-decoration: none; }
figure { margin: 1.2em 0; break-inside: avoid; page-break-inside: avoid; }
figure svg { display: block; width: 100%; height: auto; border: 1px solid var(--rule); border-radius: 4px; background: #fff; }
figcaption { font-size: 0.9rem; color: var(--muted); margin-top: 6px; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9rem; break-inside: avoid; page-break-inside: avoid; }
caption { caption-side: top; text-align: left; font-size: 0.9rem; color: var(--muted); padding-bottom: 4px; }
th, td { padding: 3px 10px; border-bottom: 1px solid var(--rule); text-align: right;
  font-variant-numeric: tabular-nums; vertical-align: top; }
thead th { border-bottom: 2px solid var(--ink); font-weight: 600; }
th[scope=row] { text-align: left; font-weight: 500; }
td.hi { font-weight: 700; color: var(--accent); }
.note { color: var(--muted); font-size: 0.92rem; }
.warning { background: #fff6e0; border-left: 4px solid #d99a00; padding: 6px 10px; }
.ok { background: #eef8ee; border-left: 4px solid #3a9a3a; padding: 6px 10px; }
ul { margin: 0.4em 0; }
.grid { display: grid; grid-template-columns: 1fr 1fr; gap: 0 18px; }
.grid figure { margin: 0.6em 0; }
@media (max-width: 760px) { .grid { grid-template-columns: 1fr; } nav ol { columns: 1; } }
@page { size: A4; margin: 14mm 12mm; }
@media print {
  body { font-size: 10.5pt; }
  main { max-width: none; padding: 0; }
  nav { display: none; }
  h2 { break-after: avoid; page-break-after: avoid; }
  h3 { break-after: avoid; page-break-after: avoid; }
  section { break-before: auto; }
  .facts, .warning, .ok { -webkit-print-color-adjust: exact; print-color-adjust: exact; }
  figure svg { border: none; }
}
"#;
