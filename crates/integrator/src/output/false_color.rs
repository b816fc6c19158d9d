//! False colour: luminance (nits, cd/m², with photometric lights) or illuminance (lux, a sensor grid) on a
//! logarithmic colour scale with a legend beside the picture, as Radiance's `falsecolor -log` shows it, for
//! reading light levels off a render. The scale, the palette and the legend's little font are this project's
//! own.

/// The palette's stops: (position on the scale, linear-ish sRGB 8-bit), dark blue for the lowest decade
/// through blue, cyan, green and yellow to red for the highest.
const STOPS: [(f32, [u8; 3]); 6] = [
    (0.0, [0, 0, 90]),
    (0.2, [0, 77, 255]),
    (0.4, [0, 217, 217]),
    (0.6, [51, 230, 26]),
    (0.8, [255, 217, 0]),
    (1.0, [255, 26, 0]),
];

/// Decades a default scale spans below its top.
const DEFAULT_DECADES: i32 = 4;
/// Width of the legend panel, and of its colour bar, in pixels.
const LEGEND_WIDTH: usize = 96;
const BAR_WIDTH: usize = 20;
/// The smallest height of the output (the legend needs room for its labels).
const MIN_HEIGHT: usize = 160;
/// Glyph scale: each font pixel is this many image pixels.
const SCALE: usize = 2;

/// The palette's colour at `t` ∈ [0, 1].
fn palette(t: f32) -> [u8; 3] {
    let t = if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 };
    let k = STOPS.iter().position(|s| s.0 >= t).unwrap_or(STOPS.len() - 1).max(1);
    let ((t0, a), (t1, b)) = (STOPS[k - 1], STOPS[k]);
    let f = (t - t0) / (t1 - t0);
    [0, 1, 2].map(|c| (f32::from(a[c]) + f * (f32::from(b[c]) - f32::from(a[c]))).round() as u8)
}

/// The scale's range (lo, hi) for luminances `y`: `range` if given, else from the power of ten at or above
/// the 99.9th percentile down [`DEFAULT_DECADES`] decades (1 down to 1e-4 for a black image).
pub(crate) fn scale_range(y: &[f32], range: Option<(f32, f32)>) -> (f32, f32) {
    if let Some(r) = range {
        return r;
    }
    let mut finite: Vec<f32> = y.iter().copied().filter(|v| v.is_finite() && *v > 0.0).collect();
    let top = if finite.is_empty() {
        1.0
    } else {
        let k = ((finite.len() - 1) as f64 * 0.999).round() as usize;
        let (_, v, _) = finite.select_nth_unstable_by(k, f32::total_cmp);
        10f32.powi(v.log10().ceil() as i32)
    };
    (top / 10f32.powi(DEFAULT_DECADES), top)
}

/// The false-colour picture of a `width` × `height` image of luminances `y` on the scale (lo, hi), with the
/// legend to its right: RGB8 pixels, row-major, and the picture's size.
pub(crate) fn false_color(
    y: &[f32],
    width: usize,
    height: usize,
    (lo, hi): (f32, f32),
    unit: &str,
) -> (Vec<u8>, usize, usize) {
    let (out_w, out_h) = (width + LEGEND_WIDTH, height.max(MIN_HEIGHT));
    let mut rgb = vec![0u8; out_w * out_h * 3];
    let (llo, lhi) = (lo.log10(), hi.log10());
    let position = |v: f32| if v > 0.0 { (v.log10() - llo) / (lhi - llo) } else { 0.0 };
    for row in 0..height {
        for col in 0..width {
            let c = palette(position(y[row * width + col]));
            rgb[(row * out_w + col) * 3..][..3].copy_from_slice(&c);
        }
    }
    // The legend: a bar from hi (top) to lo (bottom) with a label at each decade, the unit above.
    let (top, bottom) = (12 * SCALE, out_h - 6 * SCALE);
    let x0 = width + 6;
    for row in top..bottom {
        let t = 1.0 - (row - top) as f32 / (bottom - top - 1).max(1) as f32;
        let c = palette(t);
        for col in x0..x0 + BAR_WIDTH {
            rgb[(row * out_w + col) * 3..][..3].copy_from_slice(&c);
        }
    }
    let mut text = |s: &str, x: usize, y: usize| draw_text(&mut rgb, out_w, out_h, s, x, y);
    text(unit, x0, 2 * SCALE);
    let decades = (lhi - llo).round().max(1.0) as i32;
    for k in 0..=decades {
        let value = 10f32.powf(llo + k as f32 * (lhi - llo) / decades as f32);
        let t = k as f32 / decades as f32;
        let row = bottom as f32 - 1.0 - t * (bottom - top - 1) as f32;
        text(&label(value), x0 + BAR_WIDTH + 4, (row as usize).saturating_sub(5 * SCALE / 2));
    }
    (rgb, out_w, out_h)
}

/// A false-colour PNG of `values` (row-major, `width` × `height`, each value drawn as a `cell` × `cell`
/// square) with a legend in `unit` ("lux" for a sensor grid), on `range` or the default scale.
pub fn false_color_png(
    values: &[f32],
    width: usize,
    height: usize,
    cell: usize,
    range: Option<(f32, f32)>,
    unit: &str,
) -> std::result::Result<Vec<u8>, String> {
    use image::ImageEncoder as _;
    let cell = cell.max(1);
    let (w, h) = (width * cell, height * cell);
    let big: Vec<f32> = (0..w * h).map(|i| values[(i / w / cell) * width + (i % w) / cell]).collect();
    let (rgb, ow, oh) = false_color(&big, w, h, scale_range(values, range), unit);
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&rgb, ow as u32, oh as u32, image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(png)
}

/// A tick's label: plain digits from 0.001 to 99 999, else mantissa "e" exponent.
fn label(v: f32) -> String {
    if (1e-3..1e5).contains(&v) {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_owned()
    } else {
        format!("{v:.0e}")
    }
}

/// A 3 × 5 bitmap (rows top to bottom, 3 bits each, high bit left) of the characters labels use.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [0b111, 0b101, 0b101, 0b101, 0b111],
        '1' => [0b010, 0b110, 0b010, 0b010, 0b111],
        '2' => [0b111, 0b001, 0b111, 0b100, 0b111],
        '3' => [0b111, 0b001, 0b011, 0b001, 0b111],
        '4' => [0b101, 0b101, 0b111, 0b001, 0b001],
        '5' => [0b111, 0b100, 0b111, 0b001, 0b111],
        '6' => [0b111, 0b100, 0b111, 0b101, 0b111],
        '7' => [0b111, 0b001, 0b010, 0b010, 0b010],
        '8' => [0b111, 0b101, 0b111, 0b101, 0b111],
        '9' => [0b111, 0b101, 0b111, 0b001, 0b111],
        '.' => [0b000, 0b000, 0b000, 0b000, 0b010],
        '-' => [0b000, 0b000, 0b111, 0b000, 0b000],
        '+' => [0b000, 0b010, 0b111, 0b010, 0b000],
        'e' => [0b000, 0b111, 0b111, 0b100, 0b111],
        'n' => [0b000, 0b110, 0b101, 0b101, 0b101],
        'i' => [0b010, 0b000, 0b010, 0b010, 0b010],
        't' => [0b010, 0b111, 0b010, 0b010, 0b011],
        's' => [0b000, 0b111, 0b110, 0b011, 0b111],
        'l' => [0b110, 0b010, 0b010, 0b010, 0b111],
        'u' => [0b000, 0b101, 0b101, 0b101, 0b111],
        'x' => [0b000, 0b101, 0b010, 0b010, 0b101],
        _ => [0; 5],
    }
}

/// Draw `s` in white with its top-left corner at (x, y), clipped to the picture.
fn draw_text(rgb: &mut [u8], w: usize, h: usize, s: &str, x: usize, y: usize) {
    for (i, c) in s.chars().enumerate() {
        let g = glyph(c);
        for (r, bits) in g.iter().enumerate() {
            for b in 0..3 {
                if bits & (0b100 >> b) == 0 {
                    continue;
                }
                for dy in 0..SCALE {
                    for dx in 0..SCALE {
                        let (px, py) = (x + i * 4 * SCALE + b * SCALE + dx, y + r * SCALE + dy);
                        if px < w && py < h {
                            rgb[(py * w + px) * 3..][..3].copy_from_slice(&[255, 255, 255]);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scale_is_logarithmic_between_its_ends() {
        assert_eq!(palette(0.0), STOPS[0].1);
        assert_eq!(palette(1.0), STOPS[5].1);
        assert_eq!(palette(0.4), STOPS[2].1);
        assert_eq!(palette(f32::NAN), STOPS[0].1);
        // Three decades: 1, 10, 100, 1000 at 0, 1/3, 2/3, 1.
        let y = [1.0, 10.0, 100.0, 1000.0, 0.5, 5000.0, 0.0];
        let (rgb, w, h) = false_color(&y, 7, 1, (1.0, 1000.0), "nits");
        assert_eq!((w, h), (7 + LEGEND_WIDTH, MIN_HEIGHT));
        let px = |i: usize| [rgb[i * 3], rgb[i * 3 + 1], rgb[i * 3 + 2]];
        assert_eq!(px(0), STOPS[0].1);
        assert_eq!(px(1), palette(1.0 / 3.0));
        assert_eq!(px(3), STOPS[5].1);
        assert_eq!(px(4), STOPS[0].1, "below the scale: its lowest colour");
        assert_eq!(px(5), STOPS[5].1, "above: its highest");
        assert_eq!(px(6), STOPS[0].1, "black");
    }

    #[test]
    fn the_default_range_tops_at_the_decade_above_nearly_all_pixels() {
        let mut y: Vec<f32> = (0..10_000).map(|i| 1.0 + i as f32 * 0.03).collect();
        y[0] = 1e9; // one hot pixel does not set the scale
        assert_eq!(scale_range(&y, None), (1000.0 / 1e4, 1000.0));
        assert_eq!(scale_range(&[0.0; 4], None), (1e-4, 1.0));
        assert_eq!(scale_range(&y, Some((2.0, 20.0))), (2.0, 20.0));
        assert_eq!(label(1000.0), "1000");
        assert_eq!(label(0.01), "0.01");
        assert_eq!(label(1e6), "1e6");
    }
}
