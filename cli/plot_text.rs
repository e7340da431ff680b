//! The text of the PNG plots (`caustica bench`, `caustica density`), drawn with each glyph where the
//! font places it.
//!
//! plotters' own ab_glyph text (0.3.7) draws each glyph's ink box at the pen, dropping the glyph's left
//! side bearing, and truncates the glyph's vertical offset toward zero (a digit's rounds down, a
//! dot's up). In the bundled monospace font the full stop's ink sits in the middle of its cell, so
//! it landed against the digit before it and a pixel high: tick labels read "0˙2" for "0.2". The
//! labels were always "0.2" (the SVG plots, whose viewer sets the text, show them right).
//! [`GlyphText`] wraps a backend and lays the text out itself; everything else goes to the backend.

use ab_glyph::{Font, FontRef, ScaleFont, point};
use plotters::prelude::DrawingBackend;
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind, text_anchor::HPos,
    text_anchor::VPos,
};

/// A line of text as pixels: the ink as (x, y, coverage), with the line's box from (0, 0) (its left
/// edge, the font's ascent) to `size`.
#[derive(Debug, Default)]
pub struct Line {
    /// Covered pixels and how much of each (0..=1).
    pub ink: Vec<(i32, i32, f32)>,
    /// Width (the glyphs' advances and kerning) and height (ascent to descent), pixels.
    pub size: (i32, i32),
}

/// Lay `text` out in `font` at `px` pixels from ascent to descent (the scale plotters gives the
/// size), glyph by glyph from the pen at its advance and kerning, each glyph's ink at its own
/// bounds (bearing and baseline kept).
pub fn lay_out(font: &FontRef<'_>, px: f32, text: &str) -> Line {
    let scaled = font.as_scaled(px);
    let baseline = scaled.ascent();
    let mut line = Line::default();
    let mut pen = 0.0f32;
    let mut previous = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(previous) = previous {
            pen += scaled.kern(previous, id);
        }
        previous = Some(id);
        let glyph = id.with_scale_and_position(px, point(pen, baseline));
        if let Some(outline) = font.outline_glyph(glyph) {
            let bounds = outline.px_bounds();
            let (x0, y0) = (bounds.min.x as i32, bounds.min.y as i32);
            outline.draw(|x, y, coverage| {
                if coverage > 0.0 {
                    line.ink.push((x0 + x as i32, y0 + y as i32, coverage.min(1.0)));
                }
            });
        }
        pen += scaled.h_advance(id);
    }
    line.size = (pen.ceil() as i32, (scaled.ascent() - scaled.descent()).ceil() as i32);
    line
}

/// The font every plot's text is set in, bundled so that a plot looks the same on any machine.
pub(crate) static FONT: &[u8] = include_bytes!("fonts/DejaVuSansMono.ttf");

/// A backend whose text is laid out by [`lay_out`] in the bundled font (the plots register no
/// other, so the style's family is not looked at).
pub struct GlyphText<B> {
    inner: B,
    font: FontRef<'static>,
}

impl<B> GlyphText<B> {
    /// `inner`, its text drawn in the bundled font.
    pub fn new(inner: B) -> Self {
        let font = FontRef::try_from_slice(FONT).expect("the bundled font parses");
        Self { inner, font }
    }
}

impl<B: DrawingBackend> DrawingBackend for GlyphText<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.present()
    }

    fn draw_pixel(
        &mut self,
        at: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_pixel(at, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_line(from, to, style)
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_path(path, style)
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vertices: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.fill_polygon(vertices, style)
    }

    fn blit_bitmap(
        &mut self,
        at: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.blit_bitmap(at, size, src)
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let (w, h) = lay_out(&self.font, style.size() as f32, text).size;
        Ok((w.max(0) as u32, h.max(0) as u32))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        at: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let line = lay_out(&self.font, style.size() as f32, text);
        let (w, h) = line.size;
        // The anchor as plotters' own text places it, so that labels keep their places.
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -w,
            HPos::Center => -w / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -h / 2,
            VPos::Bottom => -h,
        };
        let turn = style.transform();
        for (x, y, coverage) in line.ink {
            let (x, y) = turn.transform(x + dx, y + dy);
            let ink = BackendColor { alpha: color.alpha * coverage as f64, rgb: color.rgb };
            self.inner.draw_pixel((at.0 + x, at.1 + y), ink)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box of the ink (coverage over a half) in `columns`: left, right, top, bottom.
    fn ink_box(line: &Line, columns: std::ops::Range<i32>) -> (i32, i32, i32, i32) {
        let ink: Vec<_> = line.ink.iter().filter(|p| columns.contains(&p.0) && p.2 > 0.5).collect();
        assert!(!ink.is_empty(), "no ink in columns {columns:?}");
        let fold = |f: fn(&&(i32, i32, f32)) -> i32, min: bool| {
            let values = ink.iter().map(f);
            if min { values.min().unwrap() } else { values.max().unwrap() }
        };
        (fold(|p| p.0, true), fold(|p| p.0, false), fold(|p| p.1, true), fold(|p| p.1, false))
    }

    /// "0.2" at the plots' tick size: the point stands apart from both digits, in the middle of its
    /// cell, and on their baseline (plotters' drawing put it against the 0, a pixel above it).
    #[test]
    fn a_decimal_point_sits_between_the_digits_on_their_baseline() {
        let font = FontRef::try_from_slice(FONT).unwrap();
        let px = 15.0;
        let line = lay_out(&font, px, "0.2");
        let cell = line.size.0 / 3;
        assert!(cell > 4, "a monospace cell of {cell} px");
        let zero = ink_box(&line, 0..cell);
        let point = ink_box(&line, cell..2 * cell);
        let two = ink_box(&line, 2 * cell..3 * cell);
        assert!(point.0 > zero.1 + 1 && point.1 + 1 < two.0, "0 {zero:?}, . {point:?}, 2 {two:?}");
        let middle = (point.0 + point.1) as f32 / 2.0;
        assert!((middle - 1.5 * cell as f32).abs() <= 1.5, ". centred at {middle} in cell {cell}");
        assert_eq!(point.3, zero.3, "the point's bottom row is the 0's: . {point:?}, 0 {zero:?}");
        assert_eq!(two.3, zero.3);
        assert!(point.2 > zero.2 + (zero.3 - zero.2) / 2, "the point is in the lower half: {point:?}");
    }

    #[test]
    fn the_line_box_is_the_advances_by_the_font_height() {
        let font = FontRef::try_from_slice(FONT).unwrap();
        let one = lay_out(&font, 15.0, "0").size;
        let three = lay_out(&font, 15.0, "0.2").size;
        assert!((three.0 - 3 * one.0).abs() <= 1, "{one:?} {three:?}");
        assert_eq!(three.1, 15);
        assert!(lay_out(&font, 15.0, "").ink.is_empty());
    }
}
