"""What Primer does with every setting of the Blender structs it reads: nothing changes a Cycles render silently.

Issue 31's rule: every setting of a scene, object, camera, lamp, world, material or view layer that changes a
Cycles render is either read by Primer or reported once per render (Blender's report and the log) with what Primer
does instead. COVERAGE puts each RNA property (its identifier) of each struct in exactly one class:

  READ        Primer reads it (the text says where). "depsgraph: ..." means Blender applies it to the evaluated
              depsgraph that Primer reads (transforms, modifiers, the frame), as it does for Cycles.
  OWN         Primer's own Render panel has a setting of the same meaning, shown in Cycles' place: the text names
              it (scene.primer.<name>), whatever Cycles' value is.
  REPORTED    Primer does not model it and says so: the text names the function whose note says so ("module.function"
              in addon/), often through the setting that switches it on (depth of field for the f-stop).
  NO_EFFECT   It does not change what Cycles renders for a still frame of that scene; the text says why, per group.
  UNREPORTED  It does change a Cycles render and Primer neither reads nor reports it yet: the known gaps, with why.

A struct's properties are its own: those of its base (ID, PropertyGroup, Light) are listed once, under the base.
An identifier ending in "*" exists in some of the Blender versions Primer supports (4.2 to 5.2), not all.
Nothing here renders: tests/test_blender_rna_coverage.py walks the running Blender's RNA and fails on a property
in no class (Blender grew a setting), checks that READ identifiers appear in addon/, that REPORTED functions exist
and that OWN settings are Primer's, and that the notes appear when their settings are set.
"""
from __future__ import annotations

READ, OWN, REPORTED, NO_EFFECT, UNREPORTED = "read", "own", "reported", "no effect", "unreported"
CLASSES = (READ, OWN, REPORTED, NO_EFFECT, UNREPORTED)

# Where Primer meets each struct: a path from the scene, its camera and lamp objects, world, material and view layer.
STRUCTS = {
    "ID": "every datablock (Scene, Object, Camera, Light, World, Material)",
    "PropertyGroup": "every add-on settings group (Cycles' settings)",
    "Scene": "scene", "RenderSettings": "scene.render", "CyclesRenderSettings": "scene.cycles",
    "CyclesCurveRenderSettings": "scene.cycles_curves",
    "ViewLayer": "view_layer", "CyclesRenderLayerSettings": "view_layer.cycles",
    "LayerCollection": "view_layer.layer_collection",
    "Object": "object", "CyclesObjectSettings": "object.cycles", "ObjectLightLinking": "object.light_linking",
    "CollectionLightLinking": "collection.collection_objects[i].light_linking (and collection_children[i]'s)",
    "Camera": "camera.data", "CameraDOFSettings": "camera.data.dof", "CameraStereoData": "camera.data.stereo",
    "Light": "light.data", "PointLight": "light.data", "SpotLight": "light.data", "SunLight": "light.data",
    "AreaLight": "light.data", "CyclesLightSettings": "light.data.cycles",
    "World": "world", "CyclesWorldSettings": "world.cycles", "CyclesVisibilitySettings": "world.cycles_visibility",
    "WorldLighting": "world.light_settings", "WorldMistSettings": "world.mist_settings",
    "Material": "material", "CyclesMaterialSettings": "material.cycles",
}

# Reasons shared by groups of several structs.
BOOKKEEPING = "bookkeeping of Blender's data (names, users, libraries, flags, previews): nothing rendered"
VIEWPORT = "the viewport and the interface only (display, selection, editing, overlays)"
EEVEE = "EEVEE's or Workbench's setting: Cycles does not read it"
GREASE_PENCIL = "Grease Pencil and Line Art, drawn by Blender's own engines: Cycles does not read it"
OUTPUT = "what Blender does with any engine's finished image (file format, metadata, stamps, compositing, sequencer)"
PERFORMANCE = "how fast or where Cycles renders (devices, threads, tiles, memory, debugging): the same image"
NOISE = "Cycles' sampling strategy: the same image in expectation, other noise"
VIEWPORT_RENDER = "the viewport's interactive render only (Cycles' Viewport settings), not a final render"
BAKE = "baking only, not a render"
POINTER = "a pointer to a struct whose own settings are listed under it in this table"
ANIMATION = "animation playback, keying and timeline tools: the frame's evaluated scene does not depend on it"
DEPSGRAPH = "depsgraph: Blender applies it to the evaluated scene Primer reads, as for Cycles"
VOLUMES = ("materials.volume_closures: homogeneous media and a material's heterogeneous ones (an input fed by nodes) "
           "are rendered; a world's heterogeneous one is noted and left out")
HETEROGENEOUS = ("how Cycles samples heterogeneous media (null scattering's majorant octree and step sizes, Max Steps, "
                 "voxel interpolation of Volume objects): its unbiased mean does not depend on them; Primer marches "
                 "them at its own step (core/volumes/field.py)")
MOTION = ("motion.sample_shutter: the camera and the moving and deforming meshes blurred over the shutter "
          "(motion.give_motion); what is not blurred named in motion.moving_objects_note")

COVERAGE = {
    "ID": {
        READ: {"name": "export.export_scene (names in notes, Cryptomatte hashes, light groups)"},
        NO_EFFECT: {"asset_data id_type is_editable is_embedded_data is_evaluated is_library_indirect "
                    "is_linked_packed* is_missing is_runtime_data library library_weak_reference name_full original "
                    "override_library preview session_uid tag use_extra_user use_fake_user users": BOOKKEEPING},
    },
    "PropertyGroup": {
        NO_EFFECT: {"name": BOOKKEEPING},
    },
    "Scene": {
        READ: {"camera": "export.export_scene", "world": "export.export_scene",
               "frame_current": "engine.py (the frame rendered; the seed with Animate Seed)",
               "frame_end frame_start": "engine.py (an animation's frames)",
               "render": "export.render_settings (RenderSettings, below)",
               "primer": "export.render_settings (Primer's own settings)",
               "animation_data background_set collection frame_current_final frame_float frame_subframe gravity "
               "objects rigidbody_world simulation_frame_end simulation_frame_start use_custom_simulation_range "
               "use_gravity view_layers": DEPSGRAPH},
        NO_EFFECT: {"cycles cycles_curves eevee display hydra grease_pencil_settings":
                        POINTER + " (or another engine's)",
                    "compositing_node_group* node_tree* use_nodes sequence_editor sequencer_colorspace_settings "
                    "use_stamp_note": OUTPUT,
                    "display_settings view_settings": "colour management: Blender applies it to any engine's image",
                    "audio_distance_model audio_doppler_factor audio_doppler_speed audio_volume use_audio "
                    "use_audio_scrub sync_mode": "sound",
                    "active_clip allow_preroll* frame_preview_end frame_preview_start frame_step is_nla_tweakmode "
                    "keying_sets keying_sets_all lock_frame_selection_to_range playback_loop_mode* "
                    "show_keys_from_selected_only show_subframe time_jump_delta* time_jump_unit* timeline_markers "
                    "use_preview_range": ANIMATION,
                    "annotation* cursor grease_pencil* primer_inspector safe_areas tool_settings "
                    "transform_orientation_slots unit_settings": VIEWPORT},
    },
    "RenderSettings": {
        READ: {"border_max_x border_max_y border_min_x border_min_y use_border": "export.border_rectangle",
               "resolution_percentage resolution_x resolution_y": "export.frame_size",
               "pixel_aspect_x pixel_aspect_y film_transparent": "export.render_settings",
               "engine use_persistent_data": "engine.py",
               "use_compositing": "compositor.problems (Primer's Denoise runs in the compositor)",
               "frame_map_new frame_map_old use_simplify simplify_child_particles_render simplify_subdivision_render":
                   DEPSGRAPH,
               "use_motion_blur motion_blur_position motion_blur_shutter motion_blur_shutter_curve": MOTION},
        REPORTED: {"use_multiview views views_format stereo_views use_spherical_stereo": "unmodelled.render_notes",
                   "simplify_volumes": "export.export_scene (Volume objects are noted as not rendered)"},
        NO_EFFECT: {"bake bake_bias* bake_margin* bake_margin_type* bake_samples* bake_type* bake_user_scale* "
                    "use_bake_clear* use_bake_lores_mesh* use_bake_multires* use_bake_selected_to_active* "
                    "use_bake_user_scale*": BAKE,
                    "dither_intensity ffmpeg file_extension filepath image_settings is_movie_format metadata_input "
                    "ppm_base* ppm_factor* save_output* sequencer_gl_preview stamp_background stamp_font_size "
                    "stamp_foreground stamp_note_text use_crop_to_border use_file_extension use_overwrite "
                    "use_placeholder use_render_cache use_sequencer use_sequencer_override_scene_strip "
                    "use_single_layer "
                    "use_stamp use_stamp_camera use_stamp_date use_stamp_filename use_stamp_frame "
                    "use_stamp_frame_range use_stamp_hostname use_stamp_labels use_stamp_lens use_stamp_marker "
                    "use_stamp_memory use_stamp_note use_stamp_render_time use_stamp_scene use_stamp_sequencer_strip "
                    "use_stamp_time compositor_denoise_device* compositor_denoise_final_quality* "
                    "compositor_denoise_preview_quality* compositor_device compositor_precision": OUTPUT,
                    "line_thickness line_thickness_mode use_freestyle": "Freestyle: Blender draws its lines with EEVEE "
                    "over any engine's image (RenderEngine.bl_use_custom_freestyle off, as for Cycles)",
                    "fps fps_base": "frames per second: a still frame's scene does not depend on it",
                    "threads threads_mode use_lock_interface has_multiple_engines": PERFORMANCE,
                    "anisotropic_filter* filter_size hair_subdiv hair_type use_high_quality_normals": EEVEE,
                    "preview_pixel_size simplify_child_particles simplify_subdivision use_simplify_normals": VIEWPORT,
                    "simplify_gpencil simplify_gpencil_antialiasing simplify_gpencil_modifier simplify_gpencil_onplay "
                    "simplify_gpencil_shader_fx simplify_gpencil_tint simplify_gpencil_view_fill": GREASE_PENCIL},
        UNREPORTED: {"use_texture_cache* use_auto_generate_texture_cache*": "Blender 5.2's texture cache: with .tx "
                     "files Cycles reads mip levels by a ray's footprint (distant textures a little blurrier), Primer "
                     "full-resolution pixels; whether a .tx file exists is the file system's, not yet noted"},
    },
    "CyclesRenderSettings": {
        OWN: {"use_light_tree": "light_sampling",
              "use_denoising denoiser denoising_input_passes denoising_prefilter denoising_quality denoising_use_gpu":
                  "use_denoising: Primer's Denoise (the compositor's Denoise node, its own settings)"},
        READ: {"pixel_filter_type filter_width": "export.pixel_filter: each camera sample drawn from the filter",
               "film_transparent_glass film_transparent_roughness": "export.transparent_glass (glass under the "
                                                                    "threshold keeps a camera path clear)",
               "texture_limit_render texture_limit": "materials.texture_limit_of (Simplify > Texture Limit: images "
                                                     "halved as Cycles halves them, textures.limited)",
               "texture_resolution_render* texture_resolution*": "materials.texture_resolution_of (Simplify > "
                   "Texture Resolution, Blender 5.2: images shrunk by its power of 2 as Cycles shrinks them, "
                   "textures.limited)",
               "use_camera_cull camera_cull_margin use_distance_cull distance_cull_margin":
                   "export.object_culling (Simplify > Culling: objects left out as Cycles' sync leaves them)",
               "film_exposure": "export.film_exposure: Combined and the passes of light scaled (core render.expose)",
               "use_fast_gi fast_gi_method ao_bounces_render": "export._fast_gi (Fast GI, Replace and Add, where the "
                                                               "scene follows its Cycles settings; with Primer's own "
                                                               "unmodelled.render_notes says they have none)",
               "rolling_shutter_type rolling_shutter_duration": "motion.shutter: each row's time, top to bottom",
               "samples seed use_animated_seed max_bounces diffuse_bounces glossy_bounces transmission_bounces "
               "transparent_max_bounces volume_bounces min_light_bounces caustics_reflective caustics_refractive "
               "blur_glossy "
               "sample_clamp_direct "
               "sample_clamp_indirect use_adaptive_sampling adaptive_threshold adaptive_min_samples":
                   "cycles_settings.effective: where the scene follows its Cycles settings (Render > Settings), "
                   "else Primer's own of the same meaning"},
        REPORTED: {"dicing_rate dicing_camera max_subdivisions offscreen_dicing_scale feature_set*":
                       "unmodelled.object_notes (adaptive subdivision)",
                   "volume_biased*": "unmodelled.render_notes (Primer renders heterogeneous media's unbiased mean)"},
        NO_EFFECT: {"auto_scrambling_distance direct_light_sampling_type guiding_directional_sampling_type "
                    "guiding_distribution_type guiding_roughness_threshold guiding_training_samples "
                    "light_sampling_threshold min_transparent_bounces sample_offset sample_subset_length* "
                    "sampling_pattern scrambling_distance surface_guiding_probability time_limit "
                    "use_deterministic_guiding use_guiding use_guiding_direct_light use_guiding_mis_weights "
                    "use_layer_samples use_sample_subset* use_surface_guiding use_volume_guiding "
                    "volume_guiding_probability use_pixel_jitter*": NOISE,
                    "volume_max_steps volume_step_rate": HETEROGENEOUS,
                    "ao_bounces preview_adaptive_min_samples preview_adaptive_threshold preview_denoiser "
                    "preview_denoising_input_passes preview_denoising_prefilter preview_denoising_quality "
                    "preview_denoising_start_sample preview_denoising_use_gpu preview_dicing_rate preview_pause "
                    "preview_samples preview_scrambling_distance "
                    "use_preview_adaptive_sampling use_preview_denoising volume_preview_step_rate": VIEWPORT_RENDER,
                    "debug_bvh_layout debug_bvh_time_steps debug_bvh_type debug_texture_cache_preserve_unused* "
                    "debug_use_compact_bvh debug_use_cpu_avx2 debug_use_cpu_sse42 debug_use_cuda_adaptive_compile "
                    "debug_use_hair_bvh debug_use_hip_adaptive_compile* debug_use_metal_adaptive_compile* "
                    "debug_use_optix_debug debug_use_spatial_splits debug_use_texture_cache_eviction* device "
                    "shading_system tile_size use_auto_tile": PERFORMANCE,
                    "bake_type": BAKE},
    },
    "CyclesCurveRenderSettings": {
        READ: {"shape": "export.curves_mesh (Thick and Thick Linear as tubes; Ribbons as round tubes, noted)"},
        REPORTED: {"subdivisions": "export.curves_mesh's Ribbons note (how finely Embree tessellates Cycles' ribbons; "
                                   "Primer's tubes have their own rings)"},
    },
    "ViewLayer": {
        READ: {"use_pass_ambient_occlusion use_pass_diffuse_color use_pass_diffuse_direct use_pass_diffuse_indirect "
               "use_pass_emit use_pass_environment use_pass_glossy_color use_pass_glossy_direct "
               "use_pass_glossy_indirect use_pass_material_index use_pass_normal use_pass_object_index "
               "use_pass_position use_pass_transmission_color use_pass_transmission_direct "
               "use_pass_transmission_indirect use_pass_uv use_pass_z use_pass_mist use_pass_vector":
               "engine.py (the passes Primer writes)",
               "use_pass_cryptomatte_asset use_pass_cryptomatte_material use_pass_cryptomatte_object "
               "pass_cryptomatte_depth": "engine.py, export.export_scene (Cryptomatte)",
               "lightgroups": "lightgroups.group_names", "material_override": "export.export_scene",
               "aovs": "export.shader_aovs (the shader AOVs written; the world's AOV Outputs too: export.export_world)",
               "use_strand": "export.export_scene (Filter > Strands off: no curves nor particle hair, as in Cycles)",
               "use_volumes": "export.media_of_layer (off: no media)",
               "pass_alpha_threshold": "export.export_scene (RenderSettings.pass_alpha_threshold: the data "
                                       "passes' surface)",
               "use_sky": "export.rendered_world (Filter > Environment off: no world, as Cycles' empty background)",
               "world_override*": "export.rendered_world (the view layer's world, as Cycles renders it)",
               "layer_collection": "unmodelled.holdout_objects (Holdout), unmodelled.view_layer_notes",
               "name": "engine.py (the render layer written)",
               "use_motion_blur": "motion.blurs (with Render > Motion Blur)",
               "depsgraph objects use": DEPSGRAPH},
        REPORTED: {"use_pass_shadow use_pass_subsurface_color use_pass_subsurface_direct "
                   "use_pass_subsurface_indirect use_pass_combined use_solid":
                   "unmodelled.view_layer_notes"},
        NO_EFFECT: {"active_aov active_aov_index active_layer_collection active_lightgroup active_lightgroup_index "
                    "has_export_collections": VIEWPORT,
                    "cycles eevee": POINTER + " (or another engine's)",
                    "samples": NOISE + " (a sample count of the view layer's own, with Layer Samples)",
                    "use_pass_cryptomatte_accurate": "no longer read by Cycles (Cryptomatte is always accurate)",
                    "use_ao": "not read by Cycles 5.0 (Fast GI, Add, renders the same with it off: measured)",
                    "freestyle_settings use_freestyle": "Freestyle: Blender draws its lines with EEVEE over any "
                                                        "engine's image",
                    "use_grease_pencil* use_pass_grease_pencil*": GREASE_PENCIL},
    },
    "CyclesRenderLayerSettings": {
        OWN: {"use_denoising denoising_pass_follow_reflections* denoising_pass_use_albedo_roughness_weighting*":
              "use_denoising: Primer's Denoise, for every view layer"},
        READ: {"use_pass_shadow_catcher": "export.shadow_catcher_pass (the Shadow Catcher pass; Combined as the "
                                          "catchers' matte)",
               "use_pass_volume_direct use_pass_volume_indirect": "engine.py (the Volume light passes)"},
        REPORTED: {"denoising_store_passes pass_debug_sample_count pass_render_time* "
                   "use_pass_volume_majorant* use_pass_volume_scatter* "
                   "use_pass_volume_transmit*": "unmodelled.view_layer_notes"},
    },
    "LayerCollection": {
        READ: {"holdout": "unmodelled.holdout_objects", "children collection": "unmodelled._layer_collections",
               "exclude": DEPSGRAPH, "indirect_only": "export.indirect_only (hidden from camera rays, as in Cycles)"},
        NO_EFFECT: {"hide_viewport is_visible name": VIEWPORT},
    },
    "Object": {
        READ: {"type": "export.export_scene", "material_slots": "export.MaterialTable.slot_map",
               "light_linking": "linking.LinkSets.of (Light and Shadow Linking)",
               "pass_index": "export.export_scene (Object Index pass)", "lightgroup": "lightgroups.source_group",
               "is_holdout is_shadow_catcher visible_camera visible_diffuse visible_glossy visible_shadow "
               "visible_transmission visible_volume_scatter": "export.ray_visibility",
               "shadow_terminator_geometry_offset* shadow_terminator_shading_offset*": "export._terminator_offsets",
               "particle_systems": "export.export_scene (instances; hair in unmodelled.object_notes)",
               "add_rest_position_attribute animation_data collision constraints data delta_location "
               "delta_rotation_euler delta_rotation_quaternion delta_scale dimensions field hide_render "
               "instance_collection instance_faces_scale instance_type matrix_basis matrix_local "
               "matrix_parent_inverse matrix_world modifiers location parent parent_bone "
               "parent_bone_head_tail_factor* parent_type parent_vertices pose rigid_body rigid_body_constraint "
               "rotation_axis_angle rotation_euler rotation_mode rotation_quaternion scale "
               "show_instancer_for_render show_only_shape_key soft_body track_axis up_axis "
               "use_instance_faces_scale use_instance_vertices_rotation use_parent_final_indices* "
               "use_simulation_cache vertex_groups": DEPSGRAPH},
        REPORTED: {"color": "materials.GraphReader.output (an Object Info output Primer does not evaluate is noted)",
                   "visible_raycast*": "materials.GraphReader.output (a Raycast node is noted as not evaluated)"},
        NO_EFFECT: {"active_material active_material_index active_selection_set active_shape_key "
                    "active_shape_key_index animation_visualization bound_box display display_bounds_type "
                    "display_type empty_display_size empty_display_type empty_image_depth empty_image_offset "
                    "empty_image_side hide_select hide_surface_pick* hide_viewport image_user is_from_instancer "
                    "is_from_set is_instancer lock_location lock_rotation lock_rotation_w lock_rotations_4d "
                    "lock_scale mode motion_path selection_sets* show_all_edges show_axis show_bounds "
                    "show_empty_image_only_axis_aligned show_empty_image_orthographic show_empty_image_perspective "
                    "show_in_front show_instancer_for_viewport show_name show_texture_space show_transparent "
                    "show_wire use_camera_lock_parent use_dynamic_topology_sculpting use_empty_image_alpha "
                    "use_mesh_mirror_x use_mesh_mirror_y use_mesh_mirror_z use_shape_key_edit_mode": VIEWPORT,
                    "hide_probe_plane hide_probe_sphere hide_probe_volume shadow_terminator_normal_offset*": EEVEE,
                    "grease_pencil_modifiers* lineart shader_effects use_grease_pencil_lights": GREASE_PENCIL,
                    "cycles": POINTER},
    },
    "CyclesObjectSettings": {
        READ: {"shadow_terminator_geometry_offset shadow_terminator_offset": "export._terminator_offsets "
               "(Blender 4.2 to 4.5 keep them here)",
               "motion_steps use_motion_blur": "motion.motion_steps (the camera's and each object's transforms over "
                                               "the shutter, motion.give_motion)",
               "use_deform_motion": "motion._object_state (a deforming mesh's vertices over the shutter, "
                                    "motion.give_motion, and at the Vector pass's frames, "
                                    "motion.sample_vector_frames)",
               "use_camera_cull use_distance_cull": "export.object_culling (each object's Culling flags)",
               "ao_distance": "export.instance_keywords (its own Fast GI AO Distance, core Instance.ao_distance)",
               "is_caustics_caster is_caustics_receiver": "export.instance_keywords (Shadow Caustics: core Instance "
                                                          "caustics_caster, caustics_receiver; core/integrators/mnee.py)"},
        REPORTED: {"use_adaptive_subdivision* dicing_rate*": "unmodelled.object_notes"},
    },
    "CollectionLightLinking": {
        READ: {"link_state": "linking.reached (Include or Exclude, for an object or everything in a child collection)"},
    },
    "ObjectLightLinking": {
        READ: {"blocker_collection receiver_collection": "linking.LinkSets.of (the sets and memberships of Light and "
                                                         "Shadow Linking, as Blender's depsgraph makes them)"},
    },
    "Camera": {
        READ: {"clip_end clip_start fisheye_fov fisheye_lens lens ortho_scale panorama_type sensor_fit sensor_height "
               "sensor_width shift_x shift_y": "export.export_camera",
               "type": "export.export_camera (a Custom camera: unmodelled.camera_notes)",
               "dof": "export.depth_of_field (a panorama's: unmodelled.camera_notes)",
               "central_cylindrical_radius* central_cylindrical_range_u_max* central_cylindrical_range_u_min* "
               "central_cylindrical_range_v_max* central_cylindrical_range_v_min* fisheye_polynomial_k0 "
               "fisheye_polynomial_k1 fisheye_polynomial_k2 fisheye_polynomial_k3 fisheye_polynomial_k4 "
               "latitude_max latitude_min longitude_max longitude_min": "export.panorama_settings",
               "animation_data": DEPSGRAPH},
        REPORTED: {"custom_bytecode* custom_bytecode_hash* custom_filepath* custom_mode* custom_shader* cycles_custom*":
                       "unmodelled.camera_notes (a Custom camera)",
                   "stereo": "unmodelled.render_notes (Stereoscopy)"},
        NO_EFFECT: {"angle angle_x angle_y lens_unit": "the lens in other units: Primer reads lens and sensor",
                    "background_images composition_guide_color* display_size passepartout_alpha "
                    "show_background_images show_composition_center show_composition_center_diagonal "
                    "show_composition_golden show_composition_golden_tria_a show_composition_golden_tria_b "
                    "show_composition_harmony_tri_a show_composition_harmony_tri_b show_composition_thirds "
                    "show_limits show_mist show_name show_passepartout show_safe_areas show_safe_center show_sensor":
                        VIEWPORT},
    },
    "CameraDOFSettings": {
        READ: {"aperture_blades aperture_fstop aperture_ratio aperture_rotation focus_distance focus_object "
               "focus_subtarget* use_dof": "export.depth_of_field (panoramas' too)"},
    },
    "CameraStereoData": {
        REPORTED: {"convergence_distance convergence_mode interocular_distance pivot pole_merge_angle_from "
                   "pole_merge_angle_to use_pole_merge use_spherical_stereo": "unmodelled.render_notes (Stereoscopy)"},
    },
    "Light": {
        READ: {"color exposure* temperature_color* use_temperature*": "export._light_color",
               "temperature*": "export._light_color (as `temperature_color`, Blender's colour of it)",
               "normalize* type": "export._export_light", "node_tree use_nodes": "export.light_node_factor",
               "use_shadow": "export.export_light", "animation_data": DEPSGRAPH},
        NO_EFFECT: {"cutoff_distance diffuse_factor specular_factor transmission_factor use_custom_distance "
                    "volume_factor": EEVEE,
                    "cycles": POINTER},
    },
    "PointLight": {
        READ: {"energy shadow_soft_size use_soft_falloff": "export._export_light"},
        NO_EFFECT: {"contact_shadow_bias* contact_shadow_distance* contact_shadow_thickness* shadow_buffer_bias* "
                    "shadow_buffer_clip_start shadow_color* shadow_filter_radius shadow_jitter_overblur "
                    "shadow_maximum_resolution use_absolute_resolution use_contact_shadow* use_shadow_jitter": EEVEE},
    },
    "SpotLight": {
        READ: {"energy shadow_soft_size spot_blend spot_size use_soft_falloff": "export._export_light"},
        NO_EFFECT: {"contact_shadow_bias* contact_shadow_distance* contact_shadow_thickness* shadow_buffer_bias* "
                    "shadow_buffer_clip_start shadow_color* shadow_filter_radius shadow_jitter_overblur "
                    "shadow_maximum_resolution use_absolute_resolution use_contact_shadow* use_shadow_jitter "
                    "use_square": EEVEE,
                    "show_cone": VIEWPORT},
    },
    "SunLight": {
        READ: {"angle energy": "export._export_light"},
        NO_EFFECT: {"contact_shadow_bias* contact_shadow_distance* contact_shadow_thickness* shadow_buffer_bias* "
                    "shadow_buffer_clip_start shadow_cascade_count shadow_cascade_exponent shadow_cascade_fade "
                    "shadow_cascade_max_distance shadow_color* shadow_filter_radius shadow_jitter_overblur "
                    "shadow_maximum_resolution use_contact_shadow* use_shadow_jitter": EEVEE,
                    "shadow_soft_size": "a point or spot lamp's radius: Cycles sizes a sun by its angle"},
    },
    "AreaLight": {
        READ: {"energy shape size size_y spread": "export._export_light"},
        NO_EFFECT: {"contact_shadow_bias* contact_shadow_distance* contact_shadow_thickness* shadow_buffer_bias* "
                    "shadow_buffer_clip_start shadow_color* shadow_filter_radius shadow_jitter_overblur "
                    "shadow_maximum_resolution use_absolute_resolution use_contact_shadow* use_shadow_jitter": EEVEE,
                    "shadow_soft_size": "a point or spot lamp's radius: Cycles sizes an area lamp by its size"},
    },
    "CyclesLightSettings": {
        READ: {"is_portal": "export._export_light (a portal sends no light of its own)",
               "max_bounces use_multiple_importance_sampling": "export.export_light",
               "is_caustics_light": "export.export_light (Shadow Caustics: core/integrators/mnee.py walks the light's "
                                    "samples through caster glass; unmodelled.light_notes where it does not)"},
    },
    "World": {
        READ: {"color node_tree use_nodes": "export.export_world", "lightgroup": "lightgroups.source_group",
               "light_settings": "export._ao_distance", "mist_settings": "export._mist (the Mist pass)",
               "animation_data": DEPSGRAPH},
        NO_EFFECT: {"probe_resolution sun_angle sun_shadow_filter_radius sun_shadow_jitter_overblur "
                    "sun_shadow_maximum_resolution sun_threshold use_eevee_finite_volume use_sun_shadow "
                    "use_sun_shadow_jitter": EEVEE,
                    "cycles cycles_visibility": POINTER},
    },
    "WorldLighting": {
        READ: {"distance": "export._ao_distance (the Ambient Occlusion pass, and Fast GI's rays)",
               "ao_factor": "export._fast_gi (Fast GI: Replace's world scale, Add's ambient occlusion)"},
    },
    "WorldMistSettings": {
        READ: {"depth falloff start": "export._mist (the Mist pass)"},
        NO_EFFECT: {"height intensity use_mist": "EEVEE's mist: Cycles' Mist pass reads only Start, Depth and Falloff"},
    },
    "CyclesWorldSettings": {
        READ: {"max_bounces sample_map_resolution sampling_method use_shadows*": "export.world_light_settings"},
        REPORTED: {"is_caustics_light": "unmodelled.world_notes"},
        NO_EFFECT: {"volume_sampling": NOISE,
                    "homogeneous_volume* volume_interpolation volume_step_size": HETEROGENEOUS},
    },
    "CyclesVisibilitySettings": {
        READ: {"camera diffuse glossy transmission scatter": "export.export_world"},
        NO_EFFECT: {"shadow": "not read by Cycles for the world (its Ray Visibility panel has no Shadow)"},
    },
    "Material": {
        READ: {"diffuse_color node_tree use_nodes": "materials.export_material",
               "use_transparent_shadow": "materials.export_material", "pass_index": "export.MaterialTable.index_of",
               "animation_data": DEPSGRAPH,
               "displacement_method": "materials.export_material (Bump Only as Cycles; Displacement Only and "
                                      "Displacement and Bump move the vertices: core/geometry/displacement.py)"},
        NO_EFFECT: {"alpha_threshold blend_method max_vertex_displacement metallic refraction_depth roughness "
                    "shadow_method* show_transparent_back specular_color specular_intensity surface_render_method "
                    "thickness_mode use_backface_culling use_backface_culling_lightprobe_volume "
                    "use_backface_culling_shadow use_raytrace_refraction use_screen_refraction use_sss_translucency "
                    "use_thickness_from_shadow use_transparency_overlap volume_intersection_method": EEVEE,
                    "grease_pencil is_grease_pencil line_color line_priority lineart": GREASE_PENCIL,
                    "paint_active_slot paint_clone_slot preview_render_type texture_paint_images texture_paint_slots "
                    "use_preview_world": VIEWPORT,
                    "cycles": POINTER},
    },
    "CyclesMaterialSettings": {
        READ: {"emission_sampling use_bump_map_correction": "materials.export_material"},
        REPORTED: {"homogeneous_volume*": "unmodelled.material_notes (with a Volume)"},
        NO_EFFECT: {"volume_sampling": NOISE,
                    "volume_interpolation volume_step_rate": HETEROGENEOUS},
    },
}


def entries(struct: str) -> dict:
    """Every identifier of `struct` in COVERAGE -> (class, text), its "*" taken off."""
    return {name.rstrip("*"): (kind, text) for kind, groups in COVERAGE.get(struct, {}).items()
            for names, text in groups.items() for name in names.split()}


def version_specific(struct: str) -> set:
    """The identifiers of `struct` marked "*": present in some supported Blender versions, not all."""
    return {name.rstrip("*") for groups in COVERAGE.get(struct, {}).values() for names in groups
            for name in names.split() if name.endswith("*")}


def own_properties(rna) -> list:
    """The identifiers of an RNA struct's own properties (its base's left out when COVERAGE lists the base), sorted."""
    base = rna.base if rna.base is not None and rna.base.identifier in COVERAGE else None
    return sorted(p.identifier for p in rna.properties
                  if p.identifier != "rna_type" and (base is None or p.identifier not in base.properties))


def functions(text: str) -> list:
    """The "module.function" names (of addon/) that a REPORTED or READ text names, in order."""
    import re
    return re.findall(r"\b(export|materials|unmodelled|lightgroups|compositor|motion)\.([A-Za-z_][A-Za-z_.]*[A-Za-z_])", text)
