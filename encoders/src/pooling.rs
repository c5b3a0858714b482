//! Spatial sum-pooling with an optional column mask, shared by the heat-map and spike-train
//! encoders: each sensor pixel maps to one cell of the pooled grid, or to none.

use crate::error::{Error, Result};
use crate::event::Resolution;
use std::ops::Range;

/// The pooled size: each side rounded up, so that every pixel lands in a cell.
pub fn pooled(sensor: Resolution, pool: u16) -> Resolution {
    let p = pool.max(1);
    Resolution::new(sensor.width.div_ceil(p), sensor.height.div_ceil(p))
}

/// Checks a pooling factor and a mask of pooled columns.
pub fn validate(sensor: Resolution, pool: u16, mask_cols: Option<&Range<u16>>) -> Result<()> {
    if pool == 0 {
        return Err(Error::config("pool", "must be at least 1"));
    }
    let width = pooled(sensor, pool).width;
    if let Some(m) = mask_cols
        && (m.start >= m.end || m.end > width)
    {
        return Err(Error::config(
            "mask_cols",
            format!("mask_cols {}..{} must be a non-empty range inside 0..{width}", m.start, m.end),
        ));
    }
    Ok(())
}

/// Lookup tables from sensor coordinates to the pooled cell `row * width + col`.
#[derive(Debug, Clone)]
pub struct PoolMap {
    pub output: Resolution,
    /// Pooled column of each sensor column, or `SKIP` where masked out.
    col_of_x: Vec<u32>,
    /// Offset `row * width` of each sensor row.
    row_of_y: Vec<u32>,
}

const SKIP: u32 = u32::MAX;

impl PoolMap {
    pub fn new(sensor: Resolution, pool: u16, mask_cols: Option<&Range<u16>>) -> Result<PoolMap> {
        validate(sensor, pool, mask_cols)?;
        let output = pooled(sensor, pool);
        let p = pool as u32;
        let col_of_x = (0..sensor.width as u32)
            .map(|x| match mask_cols {
                Some(m) if !(m.start as u32..m.end as u32).contains(&(x / p)) => SKIP,
                _ => x / p,
            })
            .collect();
        let row_of_y = (0..sensor.height as u32).map(|y| (y / p) * output.width as u32).collect();
        Ok(PoolMap { output, col_of_x, row_of_y })
    }

    /// The pooled cell of pixel `(x, y)`, or `None` outside the sensor or the mask.
    #[inline]
    pub fn cell(&self, x: u16, y: u16) -> Option<u32> {
        let col = *self.col_of_x.get(x as usize)?;
        if col == SKIP {
            return None;
        }
        Some(*self.row_of_y.get(y as usize)? + col)
    }

    /// [`cell`](Self::cell) without a branch on the mask, for scatter loops whose masked pixels
    /// come at random: the cell, or `u32::MAX` outside the sensor or the mask.
    #[inline]
    pub fn cell_or_max(&self, x: u16, y: u16) -> u32 {
        match (self.col_of_x.get(x as usize), self.row_of_y.get(y as usize)) {
            // a masked column's `SKIP` is `u32::MAX` (an unpredictable select: a branch there is
            // mispredicted about every other event)
            (Some(&col), Some(&row)) => std::hint::select_unpredictable(col == SKIP, SKIP, row.wrapping_add(col)),
            _ => u32::MAX,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_branchless_cell_is_the_cell_or_max_for_every_pixel_and_beyond() {
        let sensor = Resolution::new(37, 23);
        for (pool, mask) in [(1, None), (4, Some(2..7)), (3, Some(0..1))] {
            let map = PoolMap::new(sensor, pool, mask.as_ref()).unwrap();
            for y in 0..sensor.height + 3 {
                for x in 0..sensor.width + 3 {
                    assert_eq!(
                        map.cell_or_max(x, y),
                        map.cell(x, y).unwrap_or(u32::MAX),
                        "pixel ({x}, {y}), pool {pool}"
                    );
                }
            }
        }
    }
}
