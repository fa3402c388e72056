//! Object classes and axis-aligned 2D boxes.
//!
//! Boxes are in pixel coordinates with continuous corners: a box covering exactly pixel columns
//! 10..=19 is `x_min = 10, x_max = 20`, its width is `x_max − x_min = 10`, and there is no `+1`
//! anywhere (the convention of COCO and pycocotools, not of older Pascal VOC code).

use serde::{Deserialize, Serialize};

/// The three detection classes of the paper's synthetic experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    /// Cars, vans, trucks, buses.
    Vehicle,
    /// Pedestrians (and, in real-image mode, cyclists).
    Walker,
    /// Traffic signs on poles.
    TrafficSign,
}

impl Class {
    /// All classes, in COCO category-id order.
    pub const ALL: [Class; 3] = [Class::Vehicle, Class::Walker, Class::TrafficSign];

    /// The COCO `category_id` joca writes and reads (1-based, as COCO files usually are).
    pub fn coco_id(self) -> u32 {
        match self {
            Class::Vehicle => 1,
            Class::Walker => 2,
            Class::TrafficSign => 3,
        }
    }

    /// The class of a COCO `category_id` written by [`Class::coco_id`].
    pub fn from_coco_id(id: u32) -> Option<Class> {
        Class::ALL.into_iter().find(|c| c.coco_id() == id)
    }

    /// Zero-based index, e.g. the channel of a detector's heatmap.
    pub fn index(self) -> usize {
        self.coco_id() as usize - 1
    }

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Class::Vehicle => "vehicle",
            Class::Walker => "walker",
            Class::TrafficSign => "traffic_sign",
        }
    }
}

/// An axis-aligned box in pixel coordinates (continuous corners, no `+1` convention).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BBox {
    /// Left edge, pixels.
    pub x_min: f32,
    /// Top edge, pixels.
    pub y_min: f32,
    /// Right edge, pixels.
    pub x_max: f32,
    /// Bottom edge, pixels.
    pub y_max: f32,
}

impl BBox {
    /// A box from its corners.
    pub fn new(x_min: f32, y_min: f32, x_max: f32, y_max: f32) -> Self {
        Self { x_min, y_min, x_max, y_max }
    }

    /// A box from COCO's `[x, y, width, height]`.
    pub fn from_xywh(x: f32, y: f32, width: f32, height: f32) -> Self {
        Self::new(x, y, x + width, y + height)
    }

    /// COCO's `[x, y, width, height]`.
    pub fn to_xywh(&self) -> [f32; 4] {
        [self.x_min, self.y_min, self.width(), self.height()]
    }

    /// Width in pixels (0 for an inverted box).
    pub fn width(&self) -> f32 {
        (self.x_max - self.x_min).max(0.0)
    }

    /// Height in pixels (0 for an inverted box).
    pub fn height(&self) -> f32 {
        (self.y_max - self.y_min).max(0.0)
    }

    /// Area in square pixels.
    pub fn area(&self) -> f32 {
        self.width() * self.height()
    }

    /// Intersection over union, in [0, 1]; 0 when both boxes are empty.
    pub fn iou(&self, other: &BBox) -> f32 {
        let w = (self.x_max.min(other.x_max) - self.x_min.max(other.x_min)).max(0.0);
        let h = (self.y_max.min(other.y_max) - self.y_min.max(other.y_min)).max(0.0);
        let inter = w * h;
        let union = self.area() + other.area() - inter;
        if union > 0.0 { inter / union } else { 0.0 }
    }

    /// The box scaled by `sx` horizontally and `sy` vertically (image resizing).
    pub fn scaled(&self, sx: f32, sy: f32) -> BBox {
        BBox::new(self.x_min * sx, self.y_min * sy, self.x_max * sx, self.y_max * sy)
    }
}

/// A ground-truth object in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Annotation {
    /// Tight box of the object's visible pixels.
    pub bbox: BBox,
    /// Its class.
    pub class: Class,
    /// Horizontal distance from the camera to the object's centre, metres, where the source
    /// knows it (the simulator does; recorded datasets without depth do not). Evaluation
    /// reports AP and recall per distance band from it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_m: Option<f32>,
}

impl Annotation {
    /// An object of unknown distance.
    pub fn new(bbox: BBox, class: Class) -> Self {
        Self { bbox, class, distance_m: None }
    }

    /// An object `distance_m` metres from the camera.
    pub fn at_distance(bbox: BBox, class: Class, distance_m: f32) -> Self {
        Self { bbox, class, distance_m: Some(distance_m) }
    }
}

/// Smallest box width and height, pixels, that training asks the detector to find; smaller
/// reference objects are ignore regions for the training loss (a 7-px walker looks like an
/// 8-px one) but stay objects, and misses when undetected, in every evaluation.
pub const TRAINING_MIN_BOX_PX: f32 = 8.0;

/// Splits a frame's reference objects for training: boxes at least `min_box_px` wide and tall
/// stay objects, smaller ones join the ignore regions.
pub fn training_targets(
    boxes: &[Annotation],
    ignore: &[Annotation],
    min_box_px: f32,
) -> (Vec<Annotation>, Vec<Annotation>) {
    let (kept, small): (Vec<Annotation>, Vec<Annotation>) =
        boxes.iter().partition(|a| a.bbox.width() >= min_box_px && a.bbox.height() >= min_box_px);
    let mut ignore = ignore.to_vec();
    ignore.extend(small);
    (kept, ignore)
}

/// A detector output in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Predicted box.
    pub bbox: BBox,
    /// Predicted class.
    pub class: Class,
    /// Confidence in [0, 1].
    pub score: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iou_closed_form() {
        let a = BBox::new(0.0, 0.0, 10.0, 10.0);
        let b = BBox::new(5.0, 0.0, 15.0, 10.0);
        // Intersection 50, union 150.
        assert!((a.iou(&b) - 1.0 / 3.0).abs() < 1e-6);
        assert!((b.iou(&a) - a.iou(&b)).abs() < 1e-7);
        assert_eq!(a.iou(&a), 1.0);
        // Touching boxes share an edge but no area.
        assert_eq!(a.iou(&BBox::new(10.0, 0.0, 20.0, 10.0)), 0.0);
        let empty = BBox::new(3.0, 3.0, 3.0, 3.0);
        assert_eq!(empty.iou(&empty), 0.0);
    }

    #[test]
    fn coco_ids_round_trip() {
        for c in Class::ALL {
            assert_eq!(Class::from_coco_id(c.coco_id()), Some(c));
        }
        assert_eq!(Class::from_coco_id(0), None);
        assert_eq!(BBox::from_xywh(1.0, 2.0, 3.0, 4.0).to_xywh(), [1.0, 2.0, 3.0, 4.0]);
    }
}
