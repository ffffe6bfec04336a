//! The pages `grade --html` and `gallery` write: one self-contained HTML file, with its
//! images as PNG files in a folder beside it (`report.html` → `report_files/`), so that the
//! two can be copied or zipped together and opened in any browser, offline.

use image::RgbImage;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How a card is marked: a verdict of `grade`, or plain (the gallery).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    Pass,
    Fail,
    Plain,
}

/// One picture of a card, or why there is none.
pub struct Panel {
    pub label: String,
    pub image: Result<RgbImage, String>,
}

/// One image's box: a title, lines of text (the command line, the scores) and pictures
/// side by side.
pub struct Card {
    pub title: String,
    pub mark: Mark,
    pub lines: Vec<String>,
    pub panels: Vec<Panel>,
}

/// A page being written: its images go to disk as the cards come, the HTML at the end.
pub struct Page {
    path: PathBuf,
    files: PathBuf,
    body: String,
    images: usize,
    /// Each section's anchor and heading, for the links on top.
    sections: Vec<(String, String)>,
    /// Cards side by side, as many as the window holds (the gallery), rather than one a row.
    tiled: bool,
}

impl Page {
    /// A page to be written at `path`; its folder of images is created now.
    pub fn new(path: &Path) -> Result<Page, String> {
        let stem = path.file_stem().map_or("report".into(), |s| s.to_string_lossy().into_owned());
        let files = path.with_file_name(format!("{stem}_files"));
        std::fs::create_dir_all(&files).map_err(|e| format!("{}: {e}", files.display()))?;
        Ok(Page { path: path.to_path_buf(), files, body: String::new(), images: 0, sections: Vec::new(), tiled: false })
    }

    /// Cards side by side: a page of many images with one or two pictures each.
    pub fn tiled(self) -> Page {
        Page { tiled: true, ..self }
    }

    /// A section's heading, linked from the top of the page as `id`.
    pub fn section(&mut self, id: &str, text: &str) {
        let _ = writeln!(self.body, "<h2 id=\"{}\">{}</h2>", escape(id), escape(text));
        self.sections.push((id.to_string(), text.to_string()));
    }

    /// A paragraph of text (escaped).
    pub fn paragraph(&mut self, text: &str) {
        let _ = writeln!(self.body, "<p>{}</p>", escape(text));
    }

    /// Writes the card's pictures and adds it to the page.
    pub fn card(&mut self, card: &Card) -> Result<(), String> {
        let html = self.card_html(card)?;
        self.body.push_str(&html);
        Ok(())
    }

    /// Writes the card's pictures now and returns its HTML, for [`Page::push_html`] later:
    /// a page whose cards are ordered at the end need not keep their pictures until then.
    pub fn card_html(&mut self, card: &Card) -> Result<String, String> {
        let class = match card.mark {
            Mark::Pass => "card pass",
            Mark::Fail => "card fail",
            Mark::Plain => "card",
        };
        let mut html = String::new();
        let _ = writeln!(html, "<div class=\"{class}\"><h3>{}</h3>", escape(&card.title));
        for line in &card.lines {
            let _ = writeln!(html, "<div class=\"line\">{}</div>", escape(line));
        }
        html.push_str("<div class=\"panels\">\n");
        for panel in &card.panels {
            let picture = match &panel.image {
                Ok(image) => format!("<img src=\"{}\" alt=\"{}\">", self.save(image)?, escape(&panel.label)),
                Err(why) => format!("<div class=\"absent\">{}</div>", escape(why)),
            };
            let _ = writeln!(html, "<figure>{picture}<figcaption>{}</figcaption></figure>", escape(&panel.label));
        }
        html.push_str("</div></div>\n");
        Ok(html)
    }

    /// Adds HTML that [`Page::card_html`] made.
    pub fn push_html(&mut self, html: &str) {
        self.body.push_str(html);
    }

    /// Writes the HTML file, `title` on top.
    pub fn finish(self, title: &str) -> Result<(), String> {
        let links: Vec<String> = self
            .sections
            .iter()
            .map(|(id, text)| format!("<a href=\"#{}\">{}</a>", escape(id), escape(text)))
            .collect();
        let nav = if links.is_empty() { String::new() } else { format!("<nav>{}</nav>\n", links.join(" · ")) };
        let html = format!(
            "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
             <title>{title}</title><style>{STYLE}</style></head>\n<body class=\"{}\"><h1>{title}</h1>\n{nav}{}</body></html>\n",
            if self.tiled { "tiled" } else { "" },
            self.body,
            title = escape(title)
        );
        std::fs::write(&self.path, html).map_err(|e| format!("{}: {e}", self.path.display()))
    }

    /// Saves `image` as the next PNG of the folder; its address relative to the page.
    fn save(&mut self, image: &RgbImage) -> Result<String, String> {
        self.images += 1;
        let name = format!("{:04}.png", self.images);
        raycaster::image_io::write_image(&self.files.join(&name), image).map_err(|e| e.to_string())?;
        let folder = self.files.file_name().expect("named after the page").to_string_lossy();
        Ok(format!("{}/{name}", escape(&url_path(&folder))))
    }
}

/// Pictures are shown at least this wide, pixels kept square and sharp.
const STYLE: &str = "body{font-family:sans-serif;margin:1em 2em;background:#f4f4f4}\
h3{margin:.2em 0;font-family:monospace}\
.card{background:#fff;border:1px solid #ccc;border-left:8px solid #999;margin:.8em 0;padding:.5em 1em}\
.card.pass{border-left-color:#3a3}.card.fail{border-left-color:#d22}\
.tiled .card{display:inline-block;vertical-align:top;margin-right:.8em;max-width:860px}\
.tiled .line{max-width:380px}.tiled img{width:180px;min-width:0}nav{margin-bottom:1em}\
.line{font-family:monospace;font-size:90%;white-space:pre-wrap}\
.panels{display:flex;flex-wrap:wrap;gap:1em;margin-top:.5em}\
figure{margin:0}figcaption{font-size:85%;color:#444;max-width:260px}\
img{min-width:200px;max-width:400px;image-rendering:pixelated;border:1px solid #ddd}\
.absent{width:200px;height:200px;display:flex;align-items:center;justify-content:center;\
text-align:center;background:#fee;color:#900;border:1px dashed #d22;font-size:90%;padding:4px;box-sizing:border-box}";

/// A file name as a relative URL: the characters a URL reads otherwise (a space, `#`, `?`,
/// `%`) percent-encoded, so that `my report.html`'s pictures are found.
fn url_path(name: &str) -> String {
    replaced(name, &[('%', "%25"), (' ', "%20"), ('#', "%23"), ('?', "%3F")])
}

/// Text made safe to put between HTML tags or in an attribute.
pub fn escape(text: &str) -> String {
    replaced(text, &[('&', "&amp;"), ('<', "&lt;"), ('>', "&gt;"), ('"', "&quot;"), ('\'', "&#39;")])
}

/// `text` with each character of `table` replaced by its text.
fn replaced(text: &str, table: &[(char, &str)]) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match table.iter().find(|(from, _)| *from == c) {
            Some((_, to)) => out.push_str(to),
            None => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folder_names_are_urls() {
        assert_eq!(url_path("my report #2?_files"), "my%20report%20%232%3F_files");
        assert_eq!(url_path("100%_files"), "100%25_files");
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(
            escape("<a href=\"x\">Tom & 'Jerry'</a>"),
            "&lt;a href=&quot;x&quot;&gt;Tom &amp; &#39;Jerry&#39;&lt;/a&gt;"
        );
    }
}
